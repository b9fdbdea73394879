// Joint orders of the MANO layout (docs/RIG_FORMAT.md): the 16 rig joints with their parents, the MANO21
// order (16 rig joints, then the 5 fingertips) and per-finger chains. InterHand's order:
// hand/lbs.h.
#pragma once

#include <array>
#include <cstdint>

namespace handscs {

// MANO joint order: 0 wrist, 1-3 index, 4-6 middle, 7-9 pinky, 10-12 ring, 13-15 thumb (base to
// distal). Every rig must have exactly these parents (the MANO21 and InterHand orders rely on
// them).
constexpr std::array<int64_t, 16> kManoParents = {-1, 0, 1, 2,  0,  4, 5,  0,
                                                  7,  8, 0, 10, 11, 0, 13, 14};

// Fingers in the order of the tips in MANO21 and of Rig::tip_vertices.
enum Finger { kThumb = 0, kIndex = 1, kMiddle = 2, kRing = 3, kPinky = 4 };
constexpr int kFingers = 5;

// Rig joints of each finger, base to distal, indexed by Finger.
constexpr std::array<std::array<int, 3>, 5> kFingerJoints = {{
    {13, 14, 15},  // thumb
    {1, 2, 3},     // index
    {4, 5, 6},     // middle
    {10, 11, 12},  // ring
    {7, 8, 9},     // pinky
}};

// MANO21 index of each finger's tip (16 + Finger).
constexpr int kTipJoint0 = 16;

// Finger names, indexed by Finger, for logs and files.
constexpr std::array<const char*, 5> kFingerNames = {"thumb", "index", "middle", "ring", "pinky"};

// The MANO21 parent of joint j (1-20): a rig joint's parent, or for a tip its finger's last joint.
constexpr int mano21_parent(int j) {
  return j < kTipJoint0 ? static_cast<int>(kManoParents[j]) : kFingerJoints[j - kTipJoint0][2];
}

// The finger (Finger) MANO21 joint j (1-20) belongs to.
constexpr int mano21_finger(int j) {
  if (j >= kTipJoint0) return j - kTipJoint0;
  for (int f = 0; f < kFingers; ++f)
    for (int fj : kFingerJoints[f])
      if (fj == j) return f;
  return -1;  // the wrist
}

// Names of the MANO21 joints, for logs and files.
constexpr std::array<const char*, 21> kMano21Names = {
    "wrist",  "index1", "index2",    "index3",    "middle1",    "middle2",  "middle3",
    "pinky1", "pinky2", "pinky3",    "ring1",     "ring2",      "ring3",    "thumb1",
    "thumb2", "thumb3", "thumb_tip", "index_tip", "middle_tip", "ring_tip", "pinky_tip"};

}  // namespace handscs
