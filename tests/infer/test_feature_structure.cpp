// handscs-features' parts and whole (infer/feature_sets.h, infer/feature_structure.h): the blend
// transforms against the rig's own skinning, the decoder-input layouts with and without SCS, and
// the command on a briefly trained tiny avatar, its metrics recomputed by scikit-learn.
#include "catch_torch.h"

#include <cstdlib>
#include <filesystem>
#include <fstream>

#include <c10/core/InferenceMode.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "core/atomic_file.h"
#include "core/threads.h"
#include "hand/lbs.h"
#include "infer/feature_sets.h"
#include "infer/feature_structure.h"
#include "infer/pose_source.h"
#include "small_avatar.h"
#include "test_support.h"
#include "train/tiny_capture.h"
#include "train/trainer.h"

namespace {

torch::Tensor bent_pose(torch::ScalarType dtype) {
  torch::manual_seed(7);
  return (torch::rand({48}, torch::kFloat64) - 0.5).mul(0.8).to(dtype);  // up to 0.4 rad a joint
}

}  // namespace

TEST_CASE("feature sets: vec(T) is the rig's vertex transform, labels its weights' argmax") {
  handscs::Avatar avatar = handscs_test::small_double_avatar();
  const auto pose = bent_pose(torch::kFloat64);
  const auto shape = torch::zeros({10}, torch::kFloat64);
  const auto trans = torch::tensor({0.01, -0.02, 0.3}, torch::kFloat64);
  torch::NoGradGuard no_grad;
  const auto f = handscs::gaussian_features(avatar, pose, shape, trans);
  // Untrained, each Gaussian sits on its rig vertex with that vertex's weights: hand/lbs.h's own
  // per-vertex transforms and posed vertices are the reference.
  const auto reference = handscs::lbs(avatar.rig(), pose.unsqueeze(0), shape.unsqueeze(0), trans.unsqueeze(0));
  const auto ids = avatar.gaussians().vertex_ids;
  const auto vertex_t = reference.vertex_transforms[0].index_select(0, ids).slice(1, 0, 3).reshape({-1, 12});
  // The Gaussians hold the rig's weights rounded to float32 (off by up to 3e-8), hence 1e-7.
  CHECK(torch::allclose(f.transform, vertex_t, 0, 1e-7));
  CHECK(torch::allclose(f.position, reference.vertices[0].index_select(0, ids), 0, 1e-7));
  CHECK(torch::equal(f.labels, avatar.rig().weights.argmax(1).index_select(0, ids)));
  // Every label of the 16 joints occurs on the built-in hand.
  CHECK(torch::bincount(f.labels).numel() == 16);
  CHECK((torch::bincount(f.labels) > 0).all().item<bool>());
  // Decoder input with SCS: [P, e_g, e_a, vec(T)].
  const int64_t p = avatar.descriptor_dim(), d = avatar.config().embedding_dim;
  REQUIRE(f.descriptor.size(1) == p);
  REQUIRE(f.decoder_input.size(1) == p + 2 * d + 12);
  CHECK(torch::equal(f.decoder_input.slice(1, 0, p), f.descriptor));
  CHECK(torch::equal(f.decoder_input.slice(1, p, p + d), avatar.gaussians().embed_geometry));
  CHECK(torch::equal(f.decoder_input.slice(1, p + d, p + 2 * d), avatar.gaussians().embed_appearance));
  CHECK(torch::equal(f.decoder_input.slice(1, p + 2 * d), f.transform));
  CHECK(handscs::phalange_names()[15] == "thumb3");
}

TEST_CASE("feature sets: without SCS the decoder input has no P, yet P is computed (static bones)") {
  handscs::AvatarConfig config;
  config.scs.enabled = false;
  config.embedding_dim = 4;
  config.decoder_hidden = 8;
  handscs::Avatar avatar(config, handscs::load_rig_source("builtin"));
  c10::InferenceMode guard;
  const auto f = handscs::gaussian_features(avatar, bent_pose(torch::kFloat32), torch::zeros({10}),
                                            torch::zeros({3}));
  CHECK(f.descriptor.size(1) == avatar.topology().size());
  CHECK(f.descriptor_static.size(1) == avatar.topology().size());
  CHECK(f.descriptor_virtual.size(1) == 0);
  CHECK(f.decoder_input.size(1) == 8 + 12);
  CHECK(torch::equal(f.decoder_input.slice(1, 0, 8), f.embedding));
}

TEST_CASE("features command: grid, features and metrics of a tiny avatar; scikit-learn agrees") {
  handscs::set_threads(2);
  handscs::RunConfig config = handscs_test::tiny_run_config();
  const std::string run = handscs_test::fresh_dir("features_run");
  {
    handscs::Trainer trainer(config, run);
    for (int i = 0; i < 5; ++i) REQUIRE_FALSE(trainer.step().skipped);
    trainer.save_checkpoint();
  }
  handscs::FeatureStructureOptions options;
  options.checkpoint = run;
  options.out_dir = handscs_test::fresh_dir("features_out");
  options.plot = false;
  const auto result = handscs::run_feature_structure(options);
  REQUIRE(result.poses.size() == 3);  // tiny_run_config holds out 3 poses: all of them, first to last
  CHECK(result.label == "SCS");
  const auto grid = cv::imread(result.grid_png);
  REQUIRE_FALSE(grid.empty());
  CHECK(cv::countNonZero(grid.reshape(1)) > grid.total() / 20);  // hands and labels, not a black image

  std::ifstream csv(options.out_dir + "/features.csv");
  int64_t lines = 0;
  for (std::string line; std::getline(csv, line);) ++lines;
  CHECK(lines == 1 + 3 * result.gaussians);

  const auto metrics = nlohmann::json::parse(handscs::read_file(options.out_dir + "/metrics.json"));
  REQUIRE(metrics["sets"].size() == 7);
  const auto& sets = metrics["sets"];
  CHECK(sets["transform"]["dims"] == 12);
  CHECK(sets["descriptor_virtual"]["dims"] == config.model.scs.virtual_bones);
  CHECK(sets["descriptor"]["dims"].get<int64_t>() ==
        sets["descriptor_static"]["dims"].get<int64_t>() + config.model.scs.virtual_bones);
  CHECK(sets["decoder_input"]["dims"].get<int64_t>() ==
        sets["descriptor"]["dims"].get<int64_t>() + sets["embedding"]["dims"].get<int64_t>() + 12);
  // The embeddings do not change with the pose, nor does their standardisation: one value.
  const auto embedding_knn = sets["embedding"]["knn_accuracy"]["per_pose"].get<std::vector<double>>();
  CHECK(embedding_knn[0] == embedding_knn[1]);
  CHECK(embedding_knn[1] == embedding_knn[2]);
  CHECK(sets["embedding"]["knn_accuracy"]["std"].get<double>() == 0.0);
  // After 5 steps the embeddings are still their random start: close to guessing, far below P,
  // which is a function of where a Gaussian sits relative to the bones.
  const double descriptor_knn = sets["descriptor"]["knn_accuracy"]["mean"].get<double>();
  INFO("embedding " << embedding_knn[0] << ", descriptor " << descriptor_knn << ", majority "
                    << result.majority_share);
  CHECK(embedding_knn[0] < result.majority_share + 0.15);
  CHECK(descriptor_knn > 0.85);
  CHECK(sets["descriptor"]["silhouette"]["mean"].get<double>() > sets["embedding"]["silhouette"]["mean"].get<double>());

  // scikit-learn's neighbours and silhouette_score give the same numbers.
  const std::string check = "/usr/bin/python3 " + handscs_test::kSource + "/scripts/plot_features.py check " +
                            options.out_dir + " > " + options.out_dir + "/check.log 2>&1";
  const int status = std::system(check.c_str());
  INFO(handscs::read_file(options.out_dir + "/check.log"));
  CHECK(status == 0);

  // The poses and camera it wrote bring a second run to the same poses and view: same numbers.
  handscs::FeatureStructureOptions again = options;
  again.poses = options.out_dir + "/poses.json";
  again.camera = options.out_dir + "/camera.json";
  again.out_dir = handscs_test::fresh_dir("features_again");
  CHECK(handscs::read_pose_source(again.poses).size() == 3);
  handscs::run_feature_structure(again);
  CHECK(handscs::read_file(again.out_dir + "/metrics.csv") == handscs::read_file(options.out_dir + "/metrics.csv"));
  CHECK(handscs::read_file(again.out_dir + "/features.csv") == handscs::read_file(options.out_dir + "/features.csv"));
}

TEST_CASE("features command: an --out holding a training run or another metrics.csv is refused") {
  handscs::set_threads(2);
  handscs::RunConfig config = handscs_test::tiny_run_config();
  config.train.iterations = 2;
  config.train.log_every = 1;
  config.train.checkpoint_every = 2;
  const std::string run = handscs_test::fresh_dir("features_refused_run");
  handscs::Trainer(config, run).run();
  const std::string log = handscs::read_file(run + "/metrics.csv");
  REQUIRE(log.rfind("iteration,", 0) == 0);
  handscs::FeatureStructureOptions options;
  options.checkpoint = run;
  options.out_dir = run;
  options.plot = false;
  CHECK(handscs_test::error_of([&] { handscs::run_feature_structure(options); }) ==
        "--out " + run + " holds a training run (config.json, checkpoints/): its metrics.csv, the training "
        "log, would be replaced by the k-NN table; choose another --out, e.g. " + run + "/features");
  CHECK(handscs::read_file(run + "/metrics.csv") == log);

  // A copy of the log without its run is refused by its header.
  const std::string copy = handscs_test::fresh_dir("features_log_copy");
  std::filesystem::create_directories(copy);
  std::filesystem::copy_file(run + "/metrics.csv", copy + "/metrics.csv");
  CHECK(handscs_test::error_of([&] { handscs::refuse_out_holding_training_files(copy); }) ==
        copy + "/metrics.csv was not written by handscs-features (its header: \"" + log.substr(0, 60) +
            "...\") and would be replaced; choose another --out, e.g. " + copy + "/features");
  CHECK(handscs::read_file(copy + "/metrics.csv") == log);

  // A new folder, and one holding an earlier result of handscs-features, are taken.
  CHECK_NOTHROW(handscs::refuse_out_holding_training_files(run + "/features"));
  const std::string earlier = handscs_test::fresh_dir("features_earlier");
  std::filesystem::create_directories(earlier);
  handscs::write_file_atomic(earlier + "/metrics.csv", handscs::feature_scores_per_pose_csv("SCS", {}, {}));
  CHECK_NOTHROW(handscs::refuse_out_holding_training_files(earlier));
}
