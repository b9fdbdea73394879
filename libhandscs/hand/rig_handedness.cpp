// Which hand a rig's geometry forms: see rig_handedness.h.
#include "hand/rig_handedness.h"

#include <ATen/ATen.h>

#include "hand/joint_order.h"

namespace handscs {

namespace {

// Rest joints the test reads (MANO order).
constexpr int kWrist = 0;
constexpr int kIndexKnuckle = kFingerJoints[kIndex][0];
constexpr int kMiddleKnuckle = kFingerJoints[kMiddle][0];
constexpr int kPinkyKnuckle = kFingerJoints[kPinky][0];

const char* hand_name(Handedness hand) { return hand == Handedness::left ? "left" : "right"; }

}  // namespace

GeometricHandedness geometric_handedness(const Rig& rig) {
  const torch::Tensor joints =  // [16, 3] rest joints
      torch::mm(rig.j_regressor.to(torch::kFloat64), rig.v_template.to(torch::kFloat64));
  const torch::Tensor fingers = joints[kMiddleKnuckle] - joints[kWrist];
  const torch::Tensor knuckles = joints[kIndexKnuckle] - joints[kPinkyKnuckle];
  const double lengths = (fingers.norm() * knuckles.norm()).item<double>();
  GeometricHandedness result;
  if (lengths > 0) result.cosine = torch::cross(fingers, knuckles, 0)[1].item<double>() / lengths;
  if (result.cosine >= kHandednessMinCosine) result.hand = Handedness::right;
  if (result.cosine <= -kHandednessMinCosine) result.hand = Handedness::left;
  return result;
}

std::string handedness_disagreement(const Rig& rig, const std::string& source) {
  const GeometricHandedness geometry = geometric_handedness(rig);
  if (!geometry.hand || *geometry.hand == rig.handedness) return "";
  const std::string side = *geometry.hand == Handedness::right ? "+y, a right hand's back"
                                                               : "-y, a left hand's palm";
  return source + ": handedness: labelled \"" + hand_name(rig.handedness) +
         "\", but the geometry is a " + hand_name(*geometry.hand) +
         " hand: its fingers (wrist to middle knuckle) x knuckle line (pinky to index) point to " +
         side + " in MANO's frame; the rig is used as labelled";
}

}  // namespace handscs
