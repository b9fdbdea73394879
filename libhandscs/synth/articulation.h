// A hand articulation in anatomical terms (joint flexion, finger spread, thumb opposition, wrist
// pronation/flexion/deviation, all in radians) and its MANO axis-angle pose: each joint's local
// rotation is a product of rotations about the rig's anatomical axes (synth/hand_axes.h).
#pragma once

#include <array>

#include "synth/hand_axes.h"

namespace handscs {

struct HandArticulation {
  std::array<std::array<double, 3>, 5> flex{};  // [finger][joint] rad about the flexion axes
  std::array<double, 5> spread{};  // rad abduction of index..pinky (thumb and middle unused)
  double thumb_opposition = 0;     // rad about the long axis
  double pronation = 0, wrist_flex = 0, wrist_deviation = 0;  // rad, the global orientation
};

// Absolute axis-angle pose [48] (flat_hand_mean = true) of an articulation:
//   wrist = R(long, pronation) R(wrist_flex axis, wrist_flex) R(palm normal, deviation);
//   finger base = R(flex_0, flex) R(palm normal, +-spread); thumb base = R(long, +-opposition)
//   R(flex_0, flex); the other joints R(flex_k, flex).
std::array<double, 48> articulate(const HandAxes& axes, const HandArticulation& a);

// Full ranges the tissue and skin models normalise by: a right angle of flexion, and the thumb
// opposition that reaches the little finger (rad).
constexpr double kFlexionUnit = 1.5707963267948966, kFullOpposition = 1.2;

// How far the palm folds (0 flat, 1 cupped): mostly the fingers' MCP flexion, partly the thumb's
// opposition pulling the thenar side in.
double palm_fold(const HandArticulation& a);

}  // namespace handscs
