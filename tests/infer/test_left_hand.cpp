// Left hands end to end: the mirrored tiny capture (synth hand = left) with data.hand = left and the
// built-in rig trains an avatar on the built-in left hand, scores like the right-hand capture within
// run-to-run spread, and renders new poses, writing each frame's camera and PLYs other tools read.
#include "catch_torch.h"

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "core/atomic_file.h"
#include "core/threads.h"
#include "io/ply.h"
#include "render/camera_json.h"
#include "render/camera_export.h"
#include "train/tiny_capture.h"
#include "infer/avatar_render.h"
#include "infer/evaluate.h"
#include "train/trainer.h"

using handscs_test::fresh_dir;
using handscs_test::tiny_run_config;

namespace {

struct HandRun {
  std::string dir;
  handscs::Handedness rig_hand;
  double psnr = 0;
};

HandRun train_and_score(const std::string& root, const std::string& hand) {
  handscs::RunConfig config = tiny_run_config();
  config.data.root = root;
  config.data.hand = handscs::choice_value(hand, handscs::CaptureConfig::hand_names());
  HandRun run;
  run.dir = fresh_dir("left_hand_run_" + hand);
  handscs::Trainer trainer(config, run.dir);
  while (trainer.iteration() < config.train.iterations) REQUIRE_FALSE(trainer.step().skipped);
  trainer.save_checkpoint();
  run.rig_hand = trainer.avatar().rig().handedness;
  handscs::ModelEvalOptions options;
  options.checkpoint = run.dir;
  options.out_dir = run.dir + "/eval";
  const auto result = handscs::evaluate_avatar(config, options);
  REQUIRE(result.report.summary().psnr.has_value());
  run.psnr = *result.report.summary().psnr;
  return run;
}

}  // namespace

TEST_CASE("left hand: the mirrored tiny capture trains, scores and renders like the right") {
  handscs::set_threads(2);
  const std::string left_root = fresh_dir("left_hand_capture");
  handscs::SynthConfig synth = handscs::synth_preset("tiny");
  synth.hand = handscs::CaptureConfig::Hands::left;
  handscs::generate_synth_capture(synth, left_root);

  const HandRun right = train_and_score(handscs_test::tiny_capture_dir(), "right");
  const HandRun left = train_and_score(left_root, "left");
  CHECK(right.rig_hand == handscs::Handedness::right);
  CHECK(left.rig_hand == handscs::Handedness::left);  // "builtin" follows data.hand
  // Same seeds on mirror-image data: the difference is of the run-to-run kind. Measured with
  // configs/tiny.json over seeds 0-4 (README, "Left hands"): held-out PSNR right 26.48 +- 0.16 dB,
  // left 26.43 +- 0.22, paired left - right -0.05 +- 0.10 (largest -0.21). The bound is 3 standard
  // deviations of one right-hand run; before the rig followed data.hand, the left capture trained
  // the right hand's Gaussians and scored 17.4 dB.
  constexpr double kLeftRightTolerance = 0.5;  // dB
  INFO("held-out PSNR right " << right.psnr << " dB, left " << left.psnr << " dB");
  CHECK(std::abs(left.psnr - right.psnr) < kLeftRightTolerance);

  // Rendering the left avatar in a new pose from an orbit: frames, their cameras (our camera JSON
  // and nerfstudio's transforms.json) and the PLY at SH degree 3 (45 zero f_rest) or 0.
  const std::string poses = left.dir + "/poses.json";
  std::ofstream(poses) << R"({"poses": [{"pose": [0,0,0, 0,0,0.3, 0,0,0.3, 0,0,0.3,
      0,0,0,0,0,0,0,0,0, 0,0,0,0,0,0,0,0,0, 0,0,0,0,0,0,0,0,0, 0,0,0,0,0,0,0,0,0]}]})";
  handscs::AvatarRenderOptions options;
  options.checkpoint = left.dir;
  options.poses = poses;
  options.orbit = 3;
  options.export_ply = true;
  options.ply_sh_degree = 3;
  options.out_dir = left.dir + "/frames_sh3";
  REQUIRE(handscs::render_avatar(options).frames == 3);
  options.ply_sh_degree = 0;
  options.out_dir = left.dir + "/frames_sh0";
  REQUIRE(handscs::render_avatar(options).frames == 3);

  const auto transforms =
      nlohmann::json::parse(handscs::read_file(options.out_dir + "/transforms.json"));
  REQUIRE(transforms["frames"].size() == 3);
  for (int k = 0; k < 3; ++k) {
    const std::string base = "/frame_000" + std::to_string(k);
    const handscs::Camera camera = handscs::read_camera_json(options.out_dir + base + "_camera.json");
    const handscs::Camera listed =
        handscs::camera_from_nerfstudio_frame(transforms["frames"][k], "transforms.json");
    CHECK(transforms["frames"][k]["file_path"] == base.substr(1) + ".png");
    for (int i = 0; i < 9; ++i) CHECK(listed.R[i] == Approx(camera.R[i]).margin(1e-12));
    for (int i = 0; i < 3; ++i) CHECK(listed.t[i] == Approx(camera.t[i]).margin(1e-12));

    const handscs::GaussianPly sh3 = handscs::read_gaussian_ply(left.dir + "/frames_sh3" + base + ".ply");
    const handscs::GaussianPly sh0 = handscs::read_gaussian_ply(options.out_dir + base + ".ply");
    REQUIRE(sh3.f_rest.defined());
    CHECK(sh3.f_rest.size(1) == 45);
    CHECK(sh3.f_rest.abs().max().item<float>() == 0.0f);
    CHECK_FALSE(sh0.f_rest.defined());
    CHECK(torch::equal(sh3.means, sh0.means));
    CHECK(torch::equal(sh3.f_dc, sh0.f_dc));
    CHECK(torch::equal(sh3.opacity_logits, sh0.opacity_logits));
    CHECK(torch::equal(sh3.log_scales, sh0.log_scales));
    CHECK(torch::equal(sh3.rotations, sh0.rotations));
    // The pictures are the same whichever PLY was written.
    CHECK(handscs::read_file(left.dir + "/frames_sh3" + base + ".png") ==
          handscs::read_file(options.out_dir + base + ".png"));
  }
}
