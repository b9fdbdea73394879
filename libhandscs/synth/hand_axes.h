// Anatomical axes of a MANO-layout rig's rest skeleton: the forearm/long axis, the palm normal
// (oriented by the palmar/nail vertex labels, else by handedness), the wrist flexion axis, and per
// finger joint the flexion axis (rotating the bone about it moves its end towards the palm).
#pragma once

#include <array>

#include "hand/rig.h"
#include "synth/math.h"

namespace handscs {

struct HandAxes {
  synth::Vec3 long_axis, palm_normal, wrist_flex;
  synth::Vec3 thumb_palmar;                         // palmar direction of the thumb
  std::array<std::array<synth::Vec3, 3>, 5> flex;   // [finger][joint] flexion axes
  std::array<double, 5> spread_sign{};              // abduction sign (0 for thumb and middle)
  double opposition_sign = 1;
};

HandAxes rig_axes(const Rig& rig);

}  // namespace handscs
