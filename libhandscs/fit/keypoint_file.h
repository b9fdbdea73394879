// 3D hand keypoints as the fit reads them: the project's keypoint file (any named joint order,
// metres or millimetres) and InterHand2.6M's joint_3d.json, both into MANO21 order in metres.
//
// Keypoint file (JSON):
//   {"format": "handscs-keypoints", "order": "mediapipe" | "interhand" | "mano21" | "openpose",
//    "units": "m" | "mm",
//    "frames": [{"name": "000042", "right": [[x, y, z] or null, ... 21], "left": null}, ...]}
// A null point is a missing keypoint; a null or absent hand is not in the frame.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "hand/keypoint_fit.h"
#include "hand/keypoint_order.h"

namespace handscs {

struct KeypointFrame {
  std::string name;
  std::optional<HandKeypoints> right, left;
};

std::vector<KeypointFrame> read_keypoint_file(const std::string& path);

// joint_3d.json of one capture (mm, InterHand order, right hand rows 0-20, left 21-41): a frame's
// hand is present when its hand_type names it and it has valid joints.
std::vector<KeypointFrame> read_interhand_keypoints(const std::string& path, int capture);

// Throws Error naming `where` when the hand's size says the units are wrong: its median bone is
// ~20-50 mm on a real hand, so a median over 0.5 (metres) means millimetres were given, below
// 0.002 a unit a thousand times too large.
void check_keypoint_units(const HandKeypoints& hand, const std::string& where);

// A hand's keypoints reordered to MANO21 from `order`, scaled to metres; a missing point is given as
// a non-finite value or valid 0.
HandKeypoints keypoints_to_mano21(const std::array<double, 63>& points,
                                  const std::array<uint8_t, 21>& valid, KeypointOrder order,
                                  double to_metres);

}  // namespace handscs
