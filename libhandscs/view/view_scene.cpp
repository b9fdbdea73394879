#include "view/view_scene.h"

#include <chrono>
#include <cstdio>
#include <optional>
#include <set>

#include <c10/core/InferenceMode.h>
#include <opencv2/imgcodecs.hpp>
#include <spdlog/spdlog.h>
#include <torch/types.h>

#include "core/error.h"
#include "data/capture.h"
#include "data/placement.h"
#include "metrics/image_tensor.h"
#include "synth/math.h"

namespace handscs {

namespace {

std::vector<PoseFrame> held_out_poses(const RunConfig& config) {
  std::vector<PoseFrame> poses;
  if (config.data.root.empty()) return poses;
  try {
    Capture capture = Capture::open(config.data, "", "data");
    std::set<int> seen;
    for (const auto& f : capture.test()) {
      if (!seen.insert(f.pose_index).second) continue;
      PoseFrame frame;
      frame.pose = f.pose;
      frame.shape = f.shape;
      frame.trans = f.trans;
      frame.hands = f.hands;
      char name[32];
      std::snprintf(name, sizeof(name), "held_out_%03d", f.pose_index);
      frame.name = name;
      poses.push_back(frame);
    }
  } catch (const std::exception& e) {
    spdlog::warn("held-out poses: the run's capture cannot be opened ({}); sliders and gestures only", e.what());
  }
  return poses;
}

// Where the sliders' hands stand: the first held-out pose, else the run's first training frame as
// its checkpoint records it (data/placement.h; none from an older build).
std::optional<PoseFrame> slider_base(const TrainedAvatar& trained, const std::vector<PoseFrame>& held_out) {
  if (!held_out.empty()) return held_out.front();
  if (trained.placement.is_null()) return std::nullopt;
  try {
    return pose_frame_from_json(trained.placement, trained.path + ": " + kPlacementKey);
  } catch (const std::exception& e) {
    spdlog::warn("{}; the sliders' hands stand at the origin", e.what());
    return std::nullopt;
  }
}

}  // namespace

ViewScene::ViewScene(TrainedAvatar trained, std::vector<PoseFrame> held_out)
    : trained_(std::move(trained)),
      held_out_(std::move(held_out)),
      axes_(rig_axes(trained_.avatar.rig())),
      hands_(trained_) {
  const std::optional<PoseFrame> base = slider_base(trained_, held_out_);
  if (base) {
    base_.shape = base->shape;
    base_.trans = base->trans;
    base_.hands = base->hands;  // two hands: the other hand stays as captured
  }
  double extent = 0;
  for (Handedness side : {Handedness::right, Handedness::left}) {
    Avatar* avatar = trained_.hand(side);
    if (!avatar) continue;
    const torch::Tensor means = avatar->gaussians().means.detach().to(torch::kFloat64);
    const torch::Tensor centre = means.mean(0);
    for (int d = 0; d < 3; ++d) rest_centres_[side == Handedness::right ? 0 : 1][d] = centre[d].item<double>();
    extent = std::max(extent, (means.amax(0) - means.amin(0)).norm().item<double>());
  }
  if (!trained_.left.empty() && base) {
    // Two hands: frame both as the base places them.
    c10::InferenceMode guard;
    const torch::Tensor means = hands_.pose(*base, "pose " + base->name).means.to(torch::kFloat64);
    extent = (means.amax(0) - means.amin(0)).norm().item<double>();
  }
  gaussians_ = trained_.gaussian_count();
  default_view_.distance = fitting_distance(extent, default_view_.width, default_view_.height);
}

ViewScene ViewScene::open(const std::string& checkpoint, const std::string& poses) {
  TrainedAvatar trained = open_trained_avatar(checkpoint);
  std::vector<PoseFrame> held_out =
      poses.empty() ? held_out_poses(trained.config) : read_poses_for_avatar(poses, trained);
  return ViewScene(std::move(trained), std::move(held_out));
}

json ViewScene::info() const {
  json controls = json::array();
  for (const auto& spec : hand_control_specs())
    controls.push_back({{"key", spec.key}, {"label", spec.label}, {"min", spec.min}, {"max", spec.max}});
  json gestures = json::array();
  gestures.push_back({{"name", "flat (all 0)"}, {"controls", controls_to_json(HandControls{})}});
  for (const auto& g : gesture_vocabulary())
    gestures.push_back({{"name", g.name}, {"controls", controls_to_json(g)}});
  json held_out = json::array();
  for (const auto& f : held_out_) held_out.push_back(f.name);
  // The hands the sliders pose: the right one of two always, the left one where the capture places it.
  json hands = json::array({trained_.first_hand() == Handedness::right ? "right" : "left"});
  if (!trained_.left.empty() && base_.hands[1]) hands.push_back("left");
  return {{"checkpoint", trained_.path},
          {"hands", hands},
          {"gaussians", gaussians_},
          {"controls", controls},
          {"gestures", gestures},
          {"held_out", held_out},
          {"view", orbit_view_to_json(default_view_)},
          {"limits",
           {{"side", {kMinViewSide, kMaxViewSide}},
            {"pitch", kMaxViewPitch},
            {"distance", {kMinViewDistance, kMaxViewDistance}}}}};
}

PoseFrame ViewScene::pose_of(const ViewRequest& request) const {
  switch (request.source) {
    case ViewRequest::Source::held_out:
      require(request.held_out >= 0 && request.held_out < static_cast<int64_t>(held_out_.size()),
              "request.held_out: " + std::to_string(request.held_out) + " is not a held-out pose (the run's capture has " +
                  std::to_string(held_out_.size()) + ")");
      return held_out_[request.held_out];
    case ViewRequest::Source::pose:
      return request.pose;
    case ViewRequest::Source::controls:
      break;
  }
  PoseFrame frame = base_;
  const bool flat = trained_.avatar.config().flat_hand_mean;
  if (trained_.left.empty()) {  // one hand: the wrist at zero, the capture's shape and place
    frame.pose = controls_pose(trained_.avatar.rig(), axes_, flat, request.controls);
    return frame;
  }
  // Two hands: the controls bend each hand's fingers; its wrist rotation and place stay as captured,
  // so the hands keep where they stand to each other. The flat form of "controls" is the first hand's.
  std::array<const HandControls*, 2> controls{};
  for (int side = 0; side < 2; ++side)
    if (request.hand_controls[side]) controls[side] = &*request.hand_controls[side];
  if (!controls[0] && !controls[1]) controls[0] = &request.controls;
  for (int side = 0; side < 2; ++side) {
    if (!controls[side]) continue;
    auto& hand = frame.hands[side];
    if (!hand) {
      require(side == 0, "request.controls.left: nothing places the left hand (the run's capture cannot be "
                         "read, and its checkpoint, from an older build, records no placement); pose it "
                         "with a POSES file (handscs-view --poses)");
      hand = HandParams{{}, frame.shape, frame.trans, {}, {}};  // the wrist at zero
    }
    const std::array<float, 48> pose =
        side == 0 ? controls_pose(trained_.avatar.rig(), axes_, flat, *controls[side])
                  : mirrored_controls_pose(axes_, trained_.left.front().rig(), flat, *controls[side]);
    std::copy(pose.begin() + 3, pose.end(), hand->pose.begin() + 3);
  }
  const HandParams& first = frame.hands[0] ? *frame.hands[0] : *frame.hands[1];
  frame.pose = first.pose;
  frame.shape = first.shape;
  frame.trans = first.trans;
  return frame;
}

const PosedGaussians& ViewScene::posed(const PoseFrame& frame) {
  return hands_.pose(frame, "pose " + frame.name);
}

Camera ViewScene::camera_for(const OrbitView& view) const {
  HandFrame hand;
  int hands = 0;
  for (Handedness side : {Handedness::right, Handedness::left}) {
    const AvatarState* state = hands_.state(side);
    if (!state) continue;
    // The root joint's transform A_0 carries the rest hand (centre, axes) to where the pose puts it.
    const torch::Tensor a0 = state->lbs.joint_transforms[0][0].to(torch::kFloat64).contiguous();
    const double* a = a0.data_ptr<double>();
    const synth::Mat3 rotation = {a[0], a[1], a[2], a[4], a[5], a[6], a[8], a[9], a[10]};
    hand.centre = hand.centre +
                  synth::mul(rotation, rest_centres_[side == Handedness::right ? 0 : 1]) + synth::Vec3{a[3], a[7], a[11]};
    if (hands++ == 0) {  // the first hand posed (the right of two) turns the view; yaw 0 looks at its back
      hand.up = synth::mul(rotation, axes_.long_axis);
      hand.front = synth::mul(rotation, axes_.palm_normal * -1.0);
    }
  }
  hand.centre = hand.centre * (1.0 / hands);
  return orbit_view_camera(hand, view);
}

Camera ViewScene::camera_of(const ViewRequest& request) {
  const PoseFrame frame = pose_of(request);
  std::lock_guard<std::mutex> lock(mutex_);
  c10::InferenceMode guard;
  posed(frame);
  return camera_for(request.view);
}

ViewFrame ViewScene::render(const ViewRequest& request) {
  const PoseFrame frame = pose_of(request);
  std::lock_guard<std::mutex> lock(mutex_);
  c10::InferenceMode guard;
  const auto t0 = std::chrono::steady_clock::now();
  const PosedGaussians& gaussians = posed(frame);
  const Camera camera = camera_for(request.view);
  // As handscs-render: black background, the avatar's own colours (no camera's colour transform).
  const RasterSettings settings;
  const RasterOutput out = render_posed(gaussians, camera, settings);
  const cv::Mat bgr = rgb_tensor_to_mat(out.rgb.clamp(0, 1));
  std::vector<uchar> bytes;
  const bool png = request.format == ImageFormat::png;
  const std::vector<int> params =
      png ? std::vector<int>{cv::IMWRITE_PNG_COMPRESSION, 1}  // fast: a frame per request, not an archive
          : std::vector<int>{cv::IMWRITE_JPEG_QUALITY, request.quality};
  require(cv::imencode(png ? ".png" : ".jpg", bgr, bytes, params), "OpenCV cannot encode the frame");
  ViewFrame result;
  result.bytes.assign(bytes.begin(), bytes.end());
  result.content_type = png ? "image/png" : "image/jpeg";
  result.frame_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  result.gaussians = gaussians_;
  return result;
}

}  // namespace handscs
