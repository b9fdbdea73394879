// The viewer's sliders (view/hand_controls.h): their pose is synth's articulation of the same
// fractions, a slider moves only its own joint, and values outside a control's range are errors.
#include "catch_torch.h"

#include <cmath>

#include "hand/rig.h"
#include "synth/articulation.h"
#include "test_support.h"
#include "view/hand_controls.h"

namespace {

double joint_angle(const std::array<float, 48>& pose, int joint) {
  const float* a = &pose[3 * joint];
  return std::sqrt(double(a[0]) * a[0] + double(a[1]) * a[1] + double(a[2]) * a[2]);
}

}  // namespace

TEST_CASE("view controls: the pose of each control moves its joint alone, relative to hands_mean") {
  const handscs::Rig rig = handscs::load_rig_source("builtin");
  const handscs::HandAxes axes = handscs::rig_axes(rig);
  const auto flat = handscs::controls_pose(rig, axes, true, {});
  for (float v : flat) CHECK(v == 0.0f);  // the flat hand is the zero absolute pose
  // Relative to the mean pose: flat = -hands_mean on the finger joints, root untouched.
  const auto relative = handscs::controls_pose(rig, axes, false, {});
  for (int i = 0; i < 45; ++i) CHECK(relative[3 + i] == static_cast<float>(-rig.hands_mean[i].item<double>()));

  handscs::HandControls index_mcp;
  index_mcp.fingers[0][0] = 0.5;  // index MCP at half its range
  const auto bent = handscs::controls_pose(rig, axes, true, index_mcp);
  // MANO joint 1 is index1 (the MCP); synth's articulation of the same fraction is the reference.
  const auto reference = handscs::articulate(axes, handscs::gesture_articulation(index_mcp));
  for (int i = 0; i < 48; ++i) CHECK(bent[i] == static_cast<float>(reference[i]));
  CHECK(joint_angle(bent, 1) > 0.5);  // half of ~85 degrees
  for (int joint = 0; joint < 16; ++joint)
    if (joint != 1) CHECK(joint_angle(bent, joint) == 0.0);
}

TEST_CASE("view controls: JSON round trip of every gesture; bad values name the key") {
  for (const auto& gesture : handscs::gesture_vocabulary()) {
    const auto back = handscs::controls_from_json(handscs::controls_to_json(gesture), "c");
    CHECK(back.fingers == gesture.fingers);
    CHECK(back.spread == gesture.spread);
    CHECK(back.opposition == gesture.opposition);
    CHECK(back.thumb_flex == gesture.thumb_flex);
  }
  CHECK(handscs::hand_control_specs().size() == 15);
  using handscs_test::error_of;
  using handscs::json;
  CHECK(error_of([] { handscs::controls_from_json(json{{"index.mcp", 1.5}}, "c"); }) ==
        "c.index.mcp: 1.5 is outside -0.05..1.0");
  CHECK(error_of([] { handscs::controls_from_json(json{{"spread", "wide"}}, "c"); }) ==
        "c.spread: expected a number, got string");
  CHECK(error_of([] { handscs::controls_from_json(json{{"wrist", 0}}, "c"); }) ==
        "c.wrist: unknown control (index.mcp, ..., spread, thumb.opposition, thumb.flex)");
  CHECK(error_of([] { handscs::controls_from_json(json::array(), "c"); }) ==
        "c: expected an object of control values, got array");
}
