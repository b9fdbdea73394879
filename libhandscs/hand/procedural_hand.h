// The built-in procedural hand: a closed, MANO-layout skin mesh (about 1500 vertices) built around
// a 16-joint skeleton, with smooth skinning weights, a ring-average joint regressor and shape
// modes. Canonical frame as MANO's right hand: fingers along -x, back of the hand +y, thumb towards
// +z.
#pragma once

#include "hand/rig.h"

namespace handscs {

// Builds the procedural hand (deterministic, a few milliseconds). The left hand mirrors the right
// (x -> -x, see mirror_rig). Design and regions: docs/RIG_FORMAT.md, "The built-in hand".
Rig make_procedural_hand(Handedness handedness = Handedness::right);

}  // namespace handscs
