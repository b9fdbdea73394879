// The left hand of a two-hand synthetic capture (SynthConfig::hand = both). It is a right hand,
// posed and placed in a copy of the world by the one-hand code, then reflected through the plane
// z = 0 (Mz = diag(1, 1, -1)). The rest hand's thumb points along +z, so the reflection keeps the
// fingers up and the palm facing the same cameras and turns the thumb towards the right hand.
//
// In rig terms Mz = R_y(pi) Mx. Mx turns the built-in right hand into the built-in left hand
// (hand/rig_mirror.h) and each joint rotation R into Mx R Mx (synth/mirror.h); R_y(pi) then turns
// the whole hand. So the left hand's finger rotations are the mirrored ones, its global rotation is
// R_y(pi) Mx R Mx, and its translation is read off by comparing the left rig's mesh with the
// reflected one.
#pragma once

#include <array>
#include <vector>

#include "hand/rig.h"
#include "synth/capture.h"

namespace handscs {

// The left rig's axis-angle pose (48 values, global first) of a reflected right-hand pose; holds
// for poses relative to hands_mean too (the finger part is linear, the global part has no mean).
std::array<double, 48> reflected_left_pose(const std::array<double, 48>& right_pose);

// Reflects a frame's geometry through z = 0: vertices, normals, forearm and joints.
void reflect_geometry(SynthFrame& frame);

// `frames` hold right hands placed in the copy of the world, before tissue (the rig's own mesh).
// Rewrites each one's pose, annotated pose, trans and annotated trans as the left rig's values of
// the reflected hand; the geometry stays unreflected (reflect_geometry does that later). Throws
// Error when the left rig does not reproduce the reflected mesh within 0.1 mm (a convention bug).
void annotate_left_hands(const Rig& left_rig, std::vector<SynthFrame>& frames);

}  // namespace handscs
