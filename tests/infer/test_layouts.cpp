// Training, evaluation and rendering read every capture layout through the same reader: the tiny
// synthetic capture written in the project's own layout trains to the InterHand2.6M capture's
// losses exactly, EasyMocap's (lens-distorted, undistorted on load) within the resampling's bound;
// evaluation scores region masks, and a render of the held-out frames (POSES capture selection)
// runs, on each layout.
#include "catch_torch.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>

#include <opencv2/imgcodecs.hpp>

#include "core/atomic_file.h"
#include "core/threads.h"
#include "infer/evaluate.h"
#include "infer/avatar_render.h"
#include "infer/pose_source.h"
#include "synth/capture.h"
#include "synth/config.h"
#include "test_support.h"
#include "train/tiny_capture.h"
#include "train/trainer.h"

using handscs_test::fresh_dir;

namespace {

// The tiny capture in `layout` with region masks, written once per process.
const std::string& tiny_in(const std::string& layout) {
  static std::map<std::string, std::string> roots;
  auto& root = roots[layout];
  if (root.empty()) {
    root = fresh_dir("layout_" + layout);
    handscs::SynthConfig config = handscs::synth_preset("tiny");
    config.layout = handscs::choice_value(layout, handscs::SynthConfig::layout_names());
    config.effects.region_masks = true;
    handscs::generate_synth_capture(config, root);
  }
  return root;
}

constexpr int kSteps = 8;

std::vector<double> losses_on(const std::string& layout) {
  auto config = handscs_test::tiny_run_config();
  config.data.root = tiny_in(layout);
  handscs::Trainer trainer(config, fresh_dir("layout_run_" + layout));
  std::vector<double> losses;
  while (trainer.iteration() < kSteps) losses.push_back(trainer.step().loss);
  return losses;
}

// Mean |a - b| over the pixels of the training frames' ROI crops, in [0, 1] units.
double mean_crop_difference(handscs::Capture& a, handscs::Capture& b) {
  double sum = 0;
  int64_t count = 0;
  for (size_t i = 0; i < a.train().size(); ++i) {
    const auto x = a.load(a.train()[i]), y = b.load(b.train()[i]);
    REQUIRE(x.roi.x0 == y.roi.x0);
    REQUIRE(x.roi.y0 == y.roi.y0);
    REQUIRE(x.image.sizes() == y.image.sizes());
    sum += (x.image.to(torch::kFloat64) - y.image.to(torch::kFloat64)).abs().sum().item<double>();
    count += x.image.numel();
  }
  return sum / count / 255.0;
}

}  // namespace

TEST_CASE("layouts: training on the handscs and easymocap captures gives the InterHand2.6M losses") {
  handscs::set_threads(1);  // one thread: a loss is a deterministic function of the data
  const std::vector<double> reference = losses_on("interhand");
  const std::vector<double> own = losses_on("handscs");
  REQUIRE(own.size() == reference.size());
  for (size_t i = 0; i < own.size(); ++i) {
    INFO("step " << i + 1);
    CHECK(own[i] == reference[i]);  // the same images, cameras and MANO values: the same floats
  }
  // EasyMocap: the images went through the lens and back (two bilinear resamplings, a different
  // JPEG). The L1 term (weight 1) moves by at most the crops' mean difference, and the other terms
  // (mask: identical masks; SSIM, LPIPS: weight 0.01) by less; the tolerance is twice that bound,
  // for the parameters' drift over the few steps.
  auto config = handscs_test::tiny_run_config();
  config.data.root = tiny_in("interhand");
  handscs::Capture pinhole = handscs::Capture::open(config.data);
  config.data.root = tiny_in("easymocap");
  handscs::Capture undistorted = handscs::Capture::open(config.data);
  const double bound = mean_crop_difference(pinhole, undistorted);
  INFO("mean |undistorted - pinhole| over the training crops: " << bound);
  CHECK(bound > 0);
  CHECK(bound < 0.01);
  const std::vector<double> easymocap = losses_on("easymocap");
  REQUIRE(easymocap.size() == reference.size());
  for (size_t i = 0; i < easymocap.size(); ++i) {
    INFO("step " << i + 1 << ": interhand " << reference[i] << ", easymocap " << easymocap[i]);
    CHECK(std::abs(easymocap[i] - reference[i]) <= 2 * bound);
  }
  handscs::set_threads(2);
}

TEST_CASE("layouts: evaluation with regions and a render's capture poses read every layout") {
  handscs::set_threads(2);
  for (const char* layout : {"handscs", "easymocap"}) {
    INFO(layout);
    auto config = handscs_test::tiny_run_config();
    config.data.root = tiny_in(layout);
    config.train.iterations = 2;
    config.eval.lpips.weights = handscs_test::kLpipsAlexWeights;
    const auto run = fresh_dir(std::string("layout_eval_") + layout);
    {
      handscs::Trainer trainer(config, run);
      while (trainer.iteration() < config.train.iterations) trainer.step();
      trainer.save_checkpoint();
    }
    handscs::ModelEvalOptions options;
    options.checkpoint = run;
    options.out_dir = run + "/eval";
    const auto result = handscs::evaluate_avatar(config, options);
    const auto summary = result.report.summary();
    CHECK(summary.num_scored == 12);  // 3 held-out poses x 4 cameras
    CHECK(summary.regions.size() == result.report.regions.size());
    CHECK_FALSE(result.report.regions.empty());  // regions/<camera>/<frame>.png were found
    CHECK((summary.psnr && std::isfinite(*summary.psnr)));
    // The table is labelled with the capture's folder (no InterHand2.6M split and capture).
    const std::string table = handscs::read_file(options.out_dir + "/table.md");
    CHECK(table.find(std::filesystem::path(config.data.root).filename().string()) != std::string::npos);
    CHECK(table.find("Capture0") == std::string::npos);

    const std::string poses = run + "/poses.json";
    std::ofstream(poses) << R"({"capture": {"root": ")" << config.data.root
                         << R"(", "held_out_poses": 3}, "frames": "test"})";
    const auto frames = handscs::read_pose_source(poses);
    REQUIRE(frames.size() == 12);
    REQUIRE(frames[0].camera.has_value());
    // handscs-render's path end to end: the held-out frames from their own cameras.
    handscs::AvatarRenderOptions render;
    render.checkpoint = run;
    render.poses = poses;
    render.out_dir = run + "/render";
    const auto rendered = handscs::render_avatar(render);
    CHECK(rendered.frames == 12);
    CHECK(rendered.width == frames[0].camera->width);
    CHECK(rendered.height == frames[0].camera->height);
    const cv::Mat first = cv::imread(render.out_dir + "/frame_0000.png");
    CHECK(first.cols == frames[0].camera->width);
    CHECK(first.rows == frames[0].camera->height);
  }
}
