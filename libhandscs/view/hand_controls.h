// The viewer's hand controls: one slider per joint group, each a fraction of the group's full range
// in the capture generator's units (synth/gestures.h): flexion of MCP, PIP and DIP per finger,
// abduction (spread), thumb opposition and thumb flexion; and the MANO pose they make.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "core/config.h"
#include "hand/rig.h"
#include "synth/gestures.h"
#include "synth/hand_axes.h"

namespace handscs {

// Controls are held as a Gesture (its name and held_out_only unused).
using HandControls = Gesture;

struct ControlSpec {
  std::string key;    // JSON key, e.g. "index.mcp"
  std::string label;  // slider label, e.g. "index MCP"
  double min = 0, max = 1;
};

// The 15 controls in page order: index, middle, ring, pinky (MCP, PIP, DIP each), spread, thumb
// opposition, thumb flexion.
const std::vector<ControlSpec>& hand_control_specs();

// {key: fraction}; a missing key is 0. Unknown keys, non-numbers and values outside a control's
// range are errors starting with `where`.
HandControls controls_from_json(const json& object, const std::string& where);
json controls_to_json(const HandControls& controls);

// The pose [48] the controls make with the wrist (root rotation) at zero, in the avatar's
// convention: absolute with flat_hand_mean, else relative to the rig's hands_mean.
std::array<float, 48> controls_pose(const Rig& rig, const HandAxes& axes, bool flat_hand_mean,
                                    const HandControls& controls);

// The same for a left hand beside a right one: the pose the controls make with the right rig's axes,
// mirrored through x = 0 (synth/mirror.h: the built-in left rig is that mirror), in `left_rig`'s
// convention. The wrist is at zero.
std::array<float, 48> mirrored_controls_pose(const HandAxes& right_axes, const Rig& left_rig, bool flat_hand_mean,
                                             const HandControls& controls);

}  // namespace handscs
