// train.views_per_pose: an entry renders several cameras of one pose from one decoding. Which
// frames it takes (one pose, distinct cameras, every training pose once per epoch), and that the
// shared decoding trains exactly as separate entries of the same views do.
#include "catch_torch.h"

#include <filesystem>
#include <map>
#include <set>

#include "checkpoint_compare.h"
#include "core/threads.h"
#include "tiny_capture.h"
#include "run/checkpoint.h"
#include "train/trainer.h"

using handscs_test::fresh_dir;
using handscs_test::tiny_run_config;

TEST_CASE("views per pose: each entry takes distinct cameras of one pose, each pose once an epoch") {
  handscs::set_threads(2);
  auto config = tiny_run_config();  // 9 training poses x 4 cameras
  config.train.batch_size = 2;
  const int64_t per_pose = GENERATE(2, 6);  // 6: more than the pose has (4), so all of them
  config.train.views_per_pose = per_pose;
  handscs::Trainer trainer(config, fresh_dir("views_per_pose_frames"));
  std::map<int64_t, const handscs::FrameInfo*> by_index;
  std::map<int, int> cameras_of_pose;
  for (const auto& frame : trainer.capture().train()) {
    by_index[frame.index] = &frame;
    ++cameras_of_pose[frame.pose_index];
  }
  REQUIRE(cameras_of_pose.size() == 9);
  const size_t expected = static_cast<size_t>(std::min<int64_t>(per_pose, 4));
  std::vector<int> poses_in_order;  // the pose of every entry, in order
  for (int step = 0; step < 9; ++step) {  // 18 entries: two epochs over the 9 poses
    const auto r = trainer.step();
    REQUIRE(r.frames.size() == 2 * expected);
    for (size_t entry = 0; entry < 2; ++entry) {
      std::set<std::string> cameras;
      const int pose = by_index.at(r.frames[entry * expected])->pose_index;
      for (size_t k = 0; k < expected; ++k) {
        const auto* frame = by_index.at(r.frames[entry * expected + k]);
        CHECK(frame->pose_index == pose);
        cameras.insert(frame->camera_id);
      }
      CHECK(cameras.size() == expected);
      poses_in_order.push_back(pose);
    }
  }
  for (int epoch = 0; epoch < 2; ++epoch) {
    const std::set<int> poses(poses_in_order.begin() + 9 * epoch,
                              poses_in_order.begin() + 9 * (epoch + 1));
    INFO("epoch " << epoch);
    CHECK(poses.size() == 9);
  }
  CHECK(poses_in_order != std::vector<int>(poses_in_order.rbegin(), poses_in_order.rend()));
}

TEST_CASE("views per pose: 4 cameras sharing one decoding give the gradients of 4 entries of that pose") {
  handscs::set_threads(1);
  // One training pose with 4 cameras: batch_size 4 renders the same 4 views in every step as
  // views_per_pose 4, each entry with its own decoding. From one state (3 steps of the separate
  // run, resumed by both), one more step: by then the decoder gates are open, L_con pairs the step
  // with the one before, and densification statistics are accumulating. Adam's moments hold that
  // step's gradients; they must agree to rounding (the views are summed in another order). The
  // parameters themselves are not compared: Adam's first steps move a parameter by about its
  // learning rate whatever the size of its gradient, so a rounding-level gradient's sign shows.
  auto config = tiny_run_config();
  config.data.held_out_poses = 11;
  // In float: bf16 matmuls round one summed backward differently from four (~0.3% here).
  config.model.decoder_precision = handscs::AvatarConfig::DecoderPrecision::float32;
  config.train.iterations = 4;
  config.train.densify.enabled = true;
  config.train.densify.start = 2;
  config.train.densify.interval = 2;
  config.train.densify.stop = 2;  // densifies after step 2 only: the statistics of 3-4 accumulate
  config.train.densify.grad_threshold = 1e-5;
  auto separate = config, shared = config;
  separate.train.batch_size = 4;
  shared.train.views_per_pose = 4;
  const auto separate_dir = fresh_dir("views_separate"), shared_dir = fresh_dir("views_shared");
  double separate_loss = 0, shared_loss = 0;
  {
    handscs::Trainer t(separate, separate_dir);
    REQUIRE(t.capture().train().size() == 4);
    while (t.iteration() < 3) t.step();
    REQUIRE(t.avatar().gaussians().size() > 1696);  // densified after step 2
    t.save_checkpoint();
    std::filesystem::copy(separate_dir, shared_dir, std::filesystem::copy_options::recursive);
    const auto r = t.step();
    CHECK(r.frames.size() == 4);
    CHECK(r.consistency_weight == 1.0);  // the same pose: L_con is on
    separate_loss = r.loss;
    t.save_checkpoint();
  }
  {
    handscs::Trainer t(shared, shared_dir);
    REQUIRE(t.resume());
    REQUIRE(t.iteration() == 3);
    const auto r = t.step();
    REQUIRE(r.frames.size() == 4);
    CHECK(r.consistency_weight == 1.0);
    shared_loss = r.loss;
    t.save_checkpoint();
  }
  CHECK(shared_loss == Approx(separate_loss).epsilon(1e-6));
  const auto a = handscs::load_checkpoint(handscs::latest_checkpoint(separate_dir));
  const auto b = handscs::load_checkpoint(handscs::latest_checkpoint(shared_dir));
  REQUIRE(a.meta["iteration"] == 4);
  REQUIRE(b.meta["iteration"] == 4);
  const auto moments = [](const std::string& name) {
    return name.rfind("adam/", 0) == 0 || name.rfind("densify/", 0) == 0;
  };
  // Relative to each tensor's own largest value (a floor of 1e-30 keeps all-zero tensors exact).
  const auto difference = handscs_test::compare_checkpoints(a, b, 1e-30, moments);
  CHECK(difference.mismatch == "");
  INFO("largest relative difference " << difference.worst << " in " << difference.worst_name);
  CHECK(difference.worst <= 1e-5);
  // The decoders learned in this step: their moments are not all zero.
  CHECK(b.tensors.at("adam/decoders/0/m").abs().max().item<double>() > 0);
  handscs::set_threads(2);
}
