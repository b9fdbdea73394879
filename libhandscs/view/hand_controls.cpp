#include "view/hand_controls.h"

#include <cmath>

#include <torch/types.h>

#include "core/error.h"
#include "synth/articulation.h"
#include "synth/mirror.h"

namespace handscs {

namespace {

// Finger flexion from -0.05 (the slight hyperextension the capture generator's gestures reach,
// synth/gestures.cpp) to 1 (the full range); spread -1..1 (adduction..abduction); the thumb 0..1.
constexpr double kMinFlexion = -0.05;
constexpr const char* kFingerNames[4] = {"index", "middle", "ring", "pinky"};
constexpr const char* kJointNames[3] = {"mcp", "pip", "dip"};
constexpr const char* kJointLabels[3] = {"MCP", "PIP", "DIP"};

// Where each control lives in a Gesture, in hand_control_specs() order.
double& control_value(HandControls& c, size_t i) {
  if (i < 12) return c.fingers[i / 3][i % 3];
  if (i == 12) return c.spread;
  if (i == 13) return c.opposition;
  return c.thumb_flex;
}

}  // namespace

const std::vector<ControlSpec>& hand_control_specs() {
  static const std::vector<ControlSpec> specs = [] {
    std::vector<ControlSpec> s;
    for (int f = 0; f < 4; ++f)
      for (int j = 0; j < 3; ++j)
        s.push_back({std::string(kFingerNames[f]) + "." + kJointNames[j],
                     std::string(kFingerNames[f]) + " " + kJointLabels[j], kMinFlexion, 1.0});
    s.push_back({"spread", "abduction (spread)", -1.0, 1.0});
    s.push_back({"thumb.opposition", "thumb opposition", 0.0, 1.0});
    s.push_back({"thumb.flex", "thumb flexion", 0.0, 1.0});
    return s;
  }();
  return specs;
}

HandControls controls_from_json(const json& object, const std::string& where) {
  require(object.is_object(), where + ": expected an object of control values, got " + json_type_name(object));
  const auto& specs = hand_control_specs();
  HandControls controls;
  for (auto it = object.begin(); it != object.end(); ++it) {
    size_t i = 0;
    while (i < specs.size() && specs[i].key != it.key()) ++i;
    require(i < specs.size(), where + "." + it.key() + ": unknown control (index.mcp, ..., spread, "
                                  "thumb.opposition, thumb.flex)");
    const std::string key = where + "." + it.key();
    require(it->is_number(), key + ": expected a number, got " + json_type_name(*it));
    const double v = it->get<double>();
    require(std::isfinite(v) && v >= specs[i].min && v <= specs[i].max,
            key + ": " + json(v).dump() + " is outside " + json(specs[i].min).dump() + ".." +
                json(specs[i].max).dump());
    control_value(controls, i) = v;
  }
  return controls;
}

json controls_to_json(const HandControls& controls) {
  json out = json::object();
  HandControls c = controls;
  const auto& specs = hand_control_specs();
  for (size_t i = 0; i < specs.size(); ++i) out[specs[i].key] = control_value(c, i);
  return out;
}

namespace {

// An absolute pose [48] as the avatar's convention holds it: unchanged with flat_hand_mean, else the
// finger joints relative to `rig`'s hands_mean, as captures annotate them.
std::array<float, 48> in_avatar_convention(const std::array<double, 48>& absolute, const Rig& rig,
                                           bool flat_hand_mean) {
  std::array<float, 48> pose{};
  for (int i = 0; i < 48; ++i) pose[i] = static_cast<float>(absolute[i]);
  if (!flat_hand_mean) {
    const torch::Tensor mean = rig.hands_mean.to(torch::kFloat64).contiguous();
    const double* m = mean.data_ptr<double>();
    for (int i = 0; i < 45; ++i) pose[3 + i] = static_cast<float>(absolute[3 + i] - m[i]);
  }
  return pose;
}

}  // namespace

std::array<float, 48> controls_pose(const Rig& rig, const HandAxes& axes, bool flat_hand_mean,
                                    const HandControls& controls) {
  return in_avatar_convention(articulate(axes, gesture_articulation(controls)), rig, flat_hand_mean);
}

std::array<float, 48> mirrored_controls_pose(const HandAxes& right_axes, const Rig& left_rig, bool flat_hand_mean,
                                             const HandControls& controls) {
  const std::array<double, 48> right = articulate(right_axes, gesture_articulation(controls));
  return in_avatar_convention(mirror_mano_pose(right), left_rig, flat_hand_mean);
}

}  // namespace handscs
