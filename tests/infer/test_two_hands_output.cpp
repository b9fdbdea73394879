// Two-hand avatars (data.hand both) scored and rendered: handscs-eval poses both hands of each test
// frame, handscs-render draws both from two-hand poses and refuses one-hand poses by name.
#include "catch_torch.h"

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/threads.h"
#include "infer/avatar_render.h"
#include "infer/evaluate.h"
#include "train/tiny_capture.h"
#include "train/trainer.h"
#include "train/two_hand_capture.h"

using handscs_test::fresh_dir;

TEST_CASE("two hands: eval scores the test frames with both hands, render draws both") {
  handscs::set_threads(2);
  const std::string root = handscs_test::make_two_hand_capture(fresh_dir("two_hands_output"));
  handscs::RunConfig config = handscs_test::tiny_run_config();
  config.data.root = root;
  config.data.hand = handscs::CaptureConfig::Hands::both;
  config.train.iterations = 4;
  const std::string run = fresh_dir("two_hands_output_run");
  int64_t gaussians = 0;
  {
    handscs::Trainer trainer(config, run);
    gaussians = trainer.run().gaussians;
  }
  handscs::ModelEvalOptions options;
  options.checkpoint = run;
  options.out_dir = run + "/eval";
  const auto result = handscs::evaluate_avatar(config, options);
  CHECK(result.frames > 0);
  REQUIRE(result.report.summary().psnr.has_value());
  const auto summary = nlohmann::json::parse(std::ifstream(run + "/eval/summary.json"));
  CHECK(summary["rendering"]["gaussians"].get<int64_t>() == gaussians);

  // Two-hand poses from the capture: every frame shows both hands.
  const std::string poses = run + "/poses.json";
  handscs::write_file_atomic(poses, nlohmann::json{{"capture", {{"root", root}, {"hand", "both"},
                                                                {"held_out_poses", 3}}},
                                                   {"frames", "test"}, {"max_frames", 2}}.dump());
  handscs::AvatarRenderOptions render;
  render.checkpoint = run;
  render.poses = poses;
  render.out_dir = run + "/render";
  render.export_ply = true;
  const auto rendered = handscs::render_avatar(render);
  CHECK(rendered.frames == 2);
  CHECK(rendered.gaussians == gaussians);
  CHECK(std::filesystem::exists(run + "/render/frame_0001.png"));

  // One-hand poses cannot drive a two-hand avatar.
  handscs::write_file_atomic(poses, nlohmann::json{{"poses", {{{"pose", std::vector<double>(48, 0.0)}}}}}.dump());
  render.out_dir = run + "/render_one";
  CHECK_THROWS_WITH(handscs::render_avatar(render),
                    Catch::Contains("pose 0 is one hand's; the avatar has two (data.hand both)"));
}
