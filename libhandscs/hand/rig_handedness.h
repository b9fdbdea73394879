// Which hand a rig's geometry forms, from its rest joints J = j_regressor . v_template in MANO's
// frame (back of the hand towards +y):
//   cosine = ((J4 - J0) x (J1 - J7)) . y / (|J4 - J0| |J1 - J7|),  right >= 0.5, left <= -0.5.
#pragma once

#include <optional>
#include <string>

#include "hand/rig.h"

namespace handscs {

// A hand in MANO's frame gives a cosine near 1 either way (0.98 for the built-in hand); below 0.5
// its back is turned more than 60 degrees away from +y (or its knuckle line runs along its
// fingers), and the joints name no hand. scripts/convert_mano.py uses the same bound.
constexpr double kHandednessMinCosine = 0.5;

struct GeometricHandedness {
  std::optional<Handedness> hand;  // unset: the rest joints form no hand in MANO's frame
  double cosine = 0;               // of fingers x knuckle line to +y: > 0 right, < 0 left
};

// The fingers (wrist to middle knuckle) crossed with the knuckle line (pinky to index knuckle)
// point to the back of a right hand (+y) and to the palm of a left one (-y), however the hand is
// turned about y; mirroring through x = 0 flips the sign.
GeometricHandedness geometric_handedness(const Rig& rig);

// The warning for a rig whose `handedness` label the geometry contradicts, naming `source`, the
// label and the hand the geometry forms; empty when they agree or the geometry names no hand.
std::string handedness_disagreement(const Rig& rig, const std::string& source);

}  // namespace handscs
