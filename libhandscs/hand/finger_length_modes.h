// The built-in hand with per-finger length modes ("builtin+fingers"): shape modes 7, 8 and 9
// lengthen the index, ring and pinky alone, as mode 1 lengthens all four fingers (6 % per unit).
// With mode 1 they give each finger its own length, which real hands need: fitted to InterHand2.6M's
// joints, the built-in hand's ring and pinky bones come out longer than the subjects' (docs/FIT.md).
// The built-in hand itself keeps modes 7-9 zero, since synthetic captures annotate random values
// there that their images never showed.
#pragma once

#include "hand/rig.h"

namespace handscs {

// Rig source names of the variant, as load_rig_source takes them.
constexpr char kBuiltinFingersRig[] = "builtin+fingers";
constexpr char kBuiltinFingersLeftRig[] = "builtin+fingers:left";

// `builtin` (the built-in hand, either side) with modes 7-9 set from its mode 1, split by finger:
// a vertex belongs to the finger whose joints weigh most in its skinning weights.
Rig with_finger_length_modes(Rig builtin);

}  // namespace handscs
