// The viewer's sliders on a two-hand avatar: the left hand's controls make the mirror image of the
// right hand's (checked on the posed joints), each hand keeps its captured wrist and place, and a
// request may pose either hand or both.
#include "catch_torch.h"

#include <algorithm>

#include <nlohmann/json.hpp>

#include "core/threads.h"
#include "data/capture.h"
#include "hand/lbs_one_pose.h"
#include "hand/rig.h"
#include "synth/hand_axes.h"
#include "test_support.h"
#include "train/tiny_capture.h"
#include "train/trainer.h"
#include "train/two_hand_capture.h"
#include "view/hand_controls.h"
#include "view/view_scene.h"

namespace {

// The posed joints [21, 3] (float64) of `pose` on `rig`, shape and translation zero.
torch::Tensor posed_joints(const handscs::Rig& rig, const std::array<float, 48>& pose, bool flat_hand_mean) {
  handscs::LbsOptions options;
  options.flat_hand_mean = flat_hand_mean;
  const auto f64 = torch::TensorOptions().dtype(torch::kFloat64);
  const torch::Tensor p = torch::from_blob(const_cast<float*>(pose.data()), {48}, torch::kFloat32).to(torch::kFloat64);
  return handscs::lbs_one_pose(rig, p, torch::zeros({10}, f64), torch::zeros({3}, f64), options).joints[0];
}

handscs::HandControls a_gesture() {
  handscs::HandControls c;
  c.fingers[0] = {0.8, 0.5, 0.3};  // index
  c.fingers[2] = {0.2, 0.9, 0.6};  // ring
  c.spread = 0.7;
  c.opposition = 0.6;
  c.thumb_flex = 0.4;
  return c;
}

const std::string& two_hand_run() {
  static const std::string run = [] {
    handscs::set_threads(2);
    handscs::RunConfig config = handscs_test::tiny_run_config();
    handscs_test::TwoHandCaptureSpec spec;
    spec.left_offset_x = 0.16;  // m: apart, so a view framing one hand alone misses the other
    config.data.root = handscs_test::make_two_hand_capture(handscs_test::fresh_dir("view_two_hands"), spec);
    config.data.hand = handscs::CaptureConfig::Hands::both;
    const std::string dir = handscs_test::fresh_dir("view_two_hands_run");
    handscs::Trainer trainer(config, dir);
    for (int i = 0; i < 2; ++i) trainer.step();
    trainer.save_checkpoint();
    return dir;
  }();
  return run;
}

}  // namespace

TEST_CASE("view controls: a left hand's controls pose the mirror image of the right hand's") {
  const handscs::Rig right = handscs::load_rig_source("builtin");
  const handscs::Rig left = handscs::load_rig_source("builtin:left");
  const handscs::HandAxes axes = handscs::rig_axes(right);
  const handscs::HandControls controls = a_gesture();
  for (bool flat : {true, false}) {
    const torch::Tensor r = posed_joints(right, handscs::controls_pose(right, axes, flat, controls), flat);
    const torch::Tensor l = posed_joints(left, handscs::mirrored_controls_pose(axes, left, flat, controls), flat);
    // The reference: the right hand's joints reflected through x = 0.
    const torch::Tensor reflected = r * torch::tensor({-1.0, 1.0, 1.0}, torch::kFloat64);
    CHECK((l - reflected).abs().max().item<double>() < 1e-6);
    // The gesture bends the hand: its fingertips leave the flat hand's.
    const torch::Tensor flat_left = posed_joints(left, handscs::mirrored_controls_pose(axes, left, flat, {}), flat);
    CHECK((l - flat_left).norm(2, 1).max().item<double>() > 0.02);
  }
}

TEST_CASE("view scene: two hands, the sliders pose either hand and keep each wrist where captured") {
  handscs::ViewScene scene = handscs::ViewScene::open(two_hand_run());
  CHECK(scene.info()["hands"] == nlohmann::json::array({"right", "left"}));
  const handscs::ViewRequest none = handscs::parse_view_request("{\"held_out\": 0}", scene.default_view());
  const handscs::PoseFrame captured = scene.pose_of(none);
  REQUIRE(captured.hands[0]);
  REQUIRE(captured.hands[1]);

  const handscs::TrainedAvatar trained = handscs::open_trained_avatar(two_hand_run());
  const handscs::Rig& right_rig = trained.avatar.rig();
  const handscs::Rig& left_rig = trained.left.front().rig();
  const handscs::HandAxes axes = handscs::rig_axes(right_rig);
  const bool flat = trained.avatar.config().flat_hand_mean;
  const std::string gesture = handscs::controls_to_json(a_gesture()).dump();

  // Left only: the right hand as captured (its fingers too), the left's fingers the mirrored gesture.
  handscs::PoseFrame f =
      scene.pose_of(handscs::parse_view_request("{\"controls\": {\"left\": " + gesture + "}}", scene.default_view()));
  const auto left_fingers = handscs::mirrored_controls_pose(axes, left_rig, flat, a_gesture());
  CHECK(f.hands[0]->pose == captured.hands[0]->pose);
  for (int i = 0; i < 48; ++i) CHECK(f.hands[1]->pose[i] == (i < 3 ? captured.hands[1]->pose[i] : left_fingers[i]));
  CHECK(f.hands[1]->trans == captured.hands[1]->trans);
  CHECK(f.hands[1]->shape == captured.hands[1]->shape);

  // The flat form poses the first (right) hand; the left keeps its captured pose.
  f = scene.pose_of(handscs::parse_view_request("{\"controls\": " + gesture + "}", scene.default_view()));
  const auto right_fingers = handscs::controls_pose(right_rig, axes, flat, a_gesture());
  for (int i = 0; i < 48; ++i) CHECK(f.hands[0]->pose[i] == (i < 3 ? captured.hands[0]->pose[i] : right_fingers[i]));
  CHECK(f.hands[1]->pose == captured.hands[1]->pose);
  CHECK(f.pose == f.hands[0]->pose);  // the frame's own fields hold the first hand's

  // Both: the pictures differ from the captured pose's and from each one-hand change.
  const std::string both = "{\"controls\": {\"right\": " + gesture + ", \"left\": " + gesture + "}, \"format\": \"png\"}";
  const std::string left_only = "{\"controls\": {\"left\": " + gesture + "}, \"format\": \"png\"}";
  f = scene.pose_of(handscs::parse_view_request(both, scene.default_view()));
  for (int i = 3; i < 48; ++i) {
    CHECK(f.hands[0]->pose[i] == right_fingers[i]);
    CHECK(f.hands[1]->pose[i] == left_fingers[i]);
  }
  const std::string picture_both = scene.render(handscs::parse_view_request(both, scene.default_view())).bytes;
  const std::string picture_left = scene.render(handscs::parse_view_request(left_only, scene.default_view())).bytes;
  CHECK(picture_both != picture_left);
}

TEST_CASE("view scene: without its capture, a two-hand avatar's checkpoint places both hands") {
  // The checkpoint records the hands of the run's first training frame that holds both; the
  // reference is that frame read from the capture itself.
  handscs::TrainedAvatar trained = handscs::open_trained_avatar(two_hand_run());
  const handscs::Capture capture = handscs::Capture::open(trained.config.data, "", "data");
  const auto first_with_both = std::find_if(capture.train().begin(), capture.train().end(),
                                            [](const handscs::FrameInfo& f) { return f.hands[0] && f.hands[1]; });
  REQUIRE(first_with_both != capture.train().end());
  const std::string gesture = handscs::controls_to_json(a_gesture()).dump();
  const std::string left_only = "{\"controls\": {\"left\": " + gesture + "}}";
  {
    handscs::ViewScene scene(std::move(trained), {});  // no held-out poses: the capture is not read
    CHECK(scene.info()["held_out"].empty());
    CHECK(scene.info()["hands"] == nlohmann::json::array({"right", "left"}));
    const handscs::PoseFrame f = scene.pose_of(handscs::parse_view_request(left_only, scene.default_view()));
    for (int side = 0; side < 2; ++side) {
      REQUIRE(f.hands[side]);
      const handscs::HandParams& captured = *first_with_both->hands[side];
      CHECK(f.hands[side]->trans == captured.trans);
      CHECK(f.hands[side]->shape == captured.shape);
      for (int i = 0; i < 3; ++i) CHECK(f.hands[side]->pose[i] == captured.pose[i]);  // the wrist as captured
    }
    CHECK(f.hands[0]->pose == first_with_both->hands[0]->pose);  // the right hand untouched
  }
  // An older build's checkpoint records none: the left hand is refused by name, the right one posed.
  handscs::TrainedAvatar without = handscs::open_trained_avatar(two_hand_run());
  without.placement = nullptr;
  handscs::ViewScene scene(std::move(without), {});
  CHECK(scene.info()["hands"] == nlohmann::json::array({"right"}));
  CHECK_THAT(handscs_test::error_of([&] { scene.pose_of(handscs::parse_view_request(left_only, scene.default_view())); }),
             Catch::StartsWith("request.controls.left: nothing places the left hand"));
  CHECK_NOTHROW(scene.pose_of(handscs::parse_view_request("{\"controls\": " + gesture + "}", scene.default_view())));
  // A placement that is not a POSES frame is passed over (a warning), as if absent.
  handscs::TrainedAvatar malformed = handscs::open_trained_avatar(two_hand_run());
  malformed.placement["left"]["pose"] = {1.0, 2.0};
  CHECK(handscs::ViewScene(std::move(malformed), {}).info()["hands"] == nlohmann::json::array({"right"}));
}

TEST_CASE("view scene: two hands, the default view frames both") {
  handscs::ViewScene scene = handscs::ViewScene::open(two_hand_run());
  const handscs::ViewRequest request = handscs::parse_view_request("{\"held_out\": 0}", scene.default_view());
  const handscs::PoseFrame frame = scene.pose_of(request);
  const handscs::Camera camera = scene.camera_of(request);
  const handscs::TrainedAvatar trained = handscs::open_trained_avatar(two_hand_run());
  const bool flat = trained.avatar.config().flat_hand_mean;
  // Every joint of both hands, posed by the rigs themselves, projects inside the picture.
  double margin = 1e9;
  for (int side = 0; side < 2; ++side) {
    const handscs::HandParams& hand = *frame.hands[side];
    const handscs::Rig& rig = side == 0 ? trained.avatar.rig() : trained.left.front().rig();
    handscs::LbsOptions options;
    options.flat_hand_mean = flat;
    auto tensor = [](const float* v, int64_t n) {
      return torch::from_blob(const_cast<float*>(v), {n}, torch::kFloat32).to(torch::kFloat64);
    };
    const torch::Tensor joints = handscs::lbs_one_pose(rig, tensor(hand.pose.data(), 48), tensor(hand.shape.data(), 10),
                                                       tensor(hand.trans.data(), 3), options).joints[0].contiguous();
    for (int j = 0; j < 21; ++j) {
      const double* p = joints[j].data_ptr<double>();
      const auto c = camera.to_camera({p[0], p[1], p[2]});
      REQUIRE(c[2] > 0);
      const auto uv = camera.project_camera(c);
      margin = std::min({margin, uv[0], uv[1], camera.width - uv[0], camera.height - uv[1]});
    }
  }
  CHECK(margin > 0);
}

TEST_CASE("view request: controls by hand, and bad hands named") {
  const auto r = handscs::parse_view_request(R"({"controls": {"left": {"index.mcp": 0.5}}})", handscs::OrbitView{});
  CHECK(r.source == handscs::ViewRequest::Source::controls);
  CHECK_FALSE(r.hand_controls[0]);
  REQUIRE(r.hand_controls[1]);
  CHECK(r.hand_controls[1]->fingers[0][0] == 0.5);
  CHECK(handscs_test::error_of([] {
          handscs::parse_view_request(R"({"controls": {"left": {"index.mcp": 3}}})", handscs::OrbitView{});
        }) == "request.controls.left.index.mcp: 3.0 is outside -0.05..1.0");
}
