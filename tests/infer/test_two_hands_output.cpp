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
#include "infer/pose_source.h"
#include "hand/keypoint_order.h"
#include "hand/lbs_one_pose.h"
#include "run/avatar_state_io.h"
#include "train/tiny_capture.h"
#include "train/trainer.h"
#include "train/two_hand_capture.h"
#include "captured_warnings.h"
#include "test_support.h"

using handscs_test::fresh_dir;

namespace {

// The tiny run config on a fresh two-hand capture (data.hand both) named `name`.
handscs::RunConfig two_hand_config(const std::string& name, int iterations) {
  handscs::set_threads(2);
  handscs::RunConfig config = handscs_test::tiny_run_config();
  config.data.root = handscs_test::make_two_hand_capture(fresh_dir(name));
  config.data.hand = handscs::CaptureConfig::Hands::both;
  config.train.iterations = iterations;
  return config;
}

}  // namespace

TEST_CASE("two hands: eval scores the test frames with both hands, render draws both") {
  const handscs::RunConfig config = two_hand_config("two_hands_output", 4);
  const std::string& root = config.data.root;
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

TEST_CASE("two hands: interpolation and keypoint files pose each hand") {
  const handscs::RunConfig config = two_hand_config("two_hands_poses", 2);
  const std::string run = fresh_dir("two_hands_poses_run");
  { handscs::Trainer(config, run).run(); }
  handscs::TrainedAvatar trained = handscs::open_trained_avatar(run);
  const handscs::KeypointTarget target = handscs::keypoint_target(trained);
  REQUIRE(target.rigs[0] != nullptr);
  REQUIRE(target.rigs[1] != nullptr);

  // Each hand a pose without twist (the fit holds twist at zero): the rig's mean pose bent 30%
  // further, relative to hands_mean as the run's poses are, turned and moved apart.
  const auto f64 = torch::kFloat64;
  std::array<std::array<double, 48>, 2> poses{};
  const std::array<std::array<double, 3>, 2> trans = {{{0.01, -0.02, 0.03}, {-0.06, -0.02, 0.04}}};
  std::array<torch::Tensor, 2> joints;
  nlohmann::json both = nlohmann::json::object(), right_only = nlohmann::json::object();
  const auto order = handscs::mano21_from_order(handscs::KeypointOrder::mediapipe);
  for (int side = 0; side < 2; ++side) {
    const handscs::Rig& rig = *target.rigs[side];
    const auto mean = rig.hands_mean.to(f64).contiguous();
    for (int i = 3; i < 48; ++i) poses[side][i] = 0.3 * mean.data_ptr<double>()[i - 3];
    poses[side][1] = side == 0 ? 0.4 : -0.4;
    joints[side] = handscs::lbs_one_pose(rig, torch::tensor(std::vector<double>(poses[side].begin(), poses[side].end()), f64),
                                         torch::zeros({10}, f64),
                                         torch::tensor(std::vector<double>(trans[side].begin(), trans[side].end()), f64),
                                         handscs::LbsOptions{config.model.flat_hand_mean})
                       .joints.reshape({21, 3}).contiguous();
    nlohmann::json rows = nlohmann::json::array();
    for (int i = 0; i < 21; ++i) rows.push_back(nullptr);
    for (int j = 0; j < 21; ++j)
      rows[order[j]] = {1e3 * joints[side][j][0].item<double>(), 1e3 * joints[side][j][1].item<double>(),
                        1e3 * joints[side][j][2].item<double>()};
    both[side == 0 ? "right" : "left"] = rows;
    if (side == 0) right_only["right"] = rows;
  }
  both["name"] = "k0";
  right_only["name"] = "k1";
  const std::string keypoints = run + "/keypoints.json";
  handscs::write_file_atomic(keypoints, nlohmann::json{{"format", "handscs-keypoints"}, {"order", "mediapipe"},
                                                       {"units", "mm"}, {"frames", {both, right_only}}}.dump());
  const std::vector<handscs::PoseFrame> fitted = handscs::read_pose_source(keypoints, target);
  REQUIRE(fitted.size() == 2);
  CHECK(fitted[0].hands[0].has_value());
  CHECK(fitted[0].hands[1].has_value());
  CHECK(fitted[1].hands[0].has_value());
  CHECK_FALSE(fitted[1].hands[1].has_value());  // the frame without a left hand leaves it out
  for (int side = 0; side < 2; ++side) {
    // Each hand's fit, posed with its own rig, lands on the joints it came from.
    const handscs::HandParams& hand = *fitted[0].hands[side];
    const auto posed = handscs::lbs_one_pose(*target.rigs[side],
                                             torch::tensor(std::vector<float>(hand.pose.begin(), hand.pose.end())).to(f64),
                                             torch::tensor(std::vector<float>(hand.shape.begin(), hand.shape.end())).to(f64),
                                             torch::tensor(std::vector<float>(hand.trans.begin(), hand.trans.end())).to(f64),
                                             handscs::LbsOptions{config.model.flat_hand_mean})
                           .joints.reshape({21, 3});
    const double worst_mm = 1e3 * (posed - joints[side]).norm(2, {1}).max().item<double>();
    INFO("hand " << side << ": largest joint error " << worst_mm << " mm");
    CHECK(worst_mm < 1.0);
  }
  // A right-hand avatar given a file of left hands only: named, not an empty result.
  const std::string left_only = run + "/left_only.json";
  handscs::write_file_atomic(left_only, nlohmann::json{{"format", "handscs-keypoints"}, {"order", "mediapipe"},
                                                       {"units", "mm"},
                                                       {"frames", {{{"name", "k2"}, {"left", both["left"]}}}}}.dump());
  handscs::KeypointTarget right_rig_only = target;
  right_rig_only.rigs[1] = nullptr;
  CHECK_THROWS_WITH(handscs::read_pose_source(left_only, right_rig_only),
                    Catch::Contains("no frame holds the right hand"));
  CHECK(handscs::read_pose_source(left_only, target).size() == 1);  // two rigs: the left hand alone

  handscs::AvatarRenderOptions render;
  render.checkpoint = run;
  render.poses = keypoints;
  render.orbit = 1;
  render.out_dir = run + "/from_keypoints";
  CHECK(handscs::render_avatar(render).frames == 2);

  // Interpolation between two-hand poses: the ends are the poses given, every step holds both hands,
  // and each hand moves as its own one-hand interpolation would.
  auto hand_json = [&](int side) { return nlohmann::json{{"pose", poses[side]}, {"trans", trans[side]}}; };
  const nlohmann::json from = {{"right", hand_json(0)}, {"left", hand_json(1)}};
  const nlohmann::json to = {{"right", hand_json(0)}, {"left", {{"pose", std::vector<double>(48, 0.0)}}}};
  const std::string interpolation = run + "/interpolate.json";
  handscs::write_file_atomic(interpolation, nlohmann::json{{"interpolate", {{"from", from}, {"to", to}, {"steps", 3}}}}.dump());
  const std::vector<handscs::PoseFrame> steps = handscs::read_pose_source(interpolation);
  REQUIRE(steps.size() == 3);
  for (const auto& step : steps) {
    REQUIRE(step.hands[0].has_value());
    REQUIRE(step.hands[1].has_value());
  }
  for (int i = 0; i < 48; ++i) CHECK(steps[0].hands[1]->pose[i] == Approx(poses[1][i]).margin(1e-6));
  for (int i = 0; i < 48; ++i) CHECK(steps[2].hands[1]->pose[i] == Approx(0.0).margin(1e-6));
  handscs::PoseFrame left_from, left_to;
  left_from.pose = steps[0].hands[1]->pose;
  left_from.trans = steps[0].hands[1]->trans;
  left_to.pose = steps[2].hands[1]->pose;
  const handscs::PoseFrame middle = handscs::interpolate_pose(left_from, left_to, 0.5);
  for (int i = 0; i < 48; ++i) CHECK(steps[1].hands[1]->pose[i] == Approx(middle.pose[i]).margin(1e-6));
  render.poses = interpolation;
  render.out_dir = run + "/interpolated";
  CHECK(handscs::render_avatar(render).frames == 3);

  // "from" and "to" must hold the same hands.
  handscs::write_file_atomic(interpolation, nlohmann::json{{"interpolate", {{"from", from}, {"to", {{"right", hand_json(0)}}}}}}.dump());
  CHECK_THROWS_WITH(handscs::read_pose_source(interpolation), Catch::Contains("\"from\" has \"left\" hand and \"to\" has none"));
}

TEST_CASE("two hands: a one-hand avatar draws its own hand of two-hand poses, never the other's") {
  handscs::set_threads(2);
  handscs::RunConfig config = handscs_test::tiny_run_config();  // the right hand alone
  config.train.iterations = 2;
  const std::string run = fresh_dir("one_hand_two_hand_poses");
  { handscs::Trainer(config, run).run(); }
  const nlohmann::json right = {{"pose", std::vector<double>(48, 0.1)}, {"trans", {0.0, 0.0, 1.0}}};
  const nlohmann::json left = {{"pose", std::vector<double>(48, -0.3)}, {"trans", {0.1, 0.0, 1.0}}};
  handscs::AvatarRenderOptions render;
  render.checkpoint = run;
  render.orbit = 1;
  const auto render_with = [&](const std::string& name, const nlohmann::json& poses) {
    render.poses = run + "/" + name + ".json";
    handscs::write_file_atomic(render.poses, poses.dump());
    render.out_dir = run + "/" + name;
    handscs::render_avatar(render);
    return handscs::read_file(render.out_dir + "/frame_0000.png");
  };
  // The right hand of a two-hand pose draws as the same pose given alone; the left is named.
  const std::string alone = render_with("alone", {{"poses", {right}}});
  {
    handscs_test::CapturedWarnings warnings;
    CHECK(render_with("both", {{"poses", {{{"right", right}, {"left", left}}}}}) == alone);
    CHECK(warnings.text().find("1 of 1 poses give the left hand too; the avatar has the right hand "
                               "alone (data.hand right), so only that hand is drawn") != std::string::npos);
  }
  // A pose with the left hand alone was drawn with the left hand's parameters on the right avatar.
  CHECK(handscs_test::error_of([&] { render_with("left", {{"poses", {{{"left", left}}}}}); }) ==
        run + "/left.json: pose 0 has no right hand, and the avatar is the right hand's alone "
              "(data.hand right)");
}
