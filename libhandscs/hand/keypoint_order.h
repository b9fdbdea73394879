// Named orders of 21 hand keypoints and their map to the library's MANO21 order (hand/joint_order.h):
// mano21 itself, InterHand2.6M's (thumb tip..base, index, middle, ring, pinky, wrist) and
// MediaPipe's, which OpenPose and MMPose's hand models share (wrist, then each finger base to tip).
#pragma once

#include <array>
#include <string>
#include <vector>

namespace handscs {

enum class KeypointOrder { mano21, interhand, mediapipe };

// The names files and configs use: "mano21", "interhand", "mediapipe" (also "openpose").
KeypointOrder keypoint_order_from_name(const std::string& name, const std::string& where);
std::string keypoint_order_name(KeypointOrder order);
std::vector<std::string> keypoint_order_names();

// mano21[i] = keypoints[index[i]]: where each MANO21 joint sits in a file of that order.
std::array<int, 21> mano21_from_order(KeypointOrder order);

// MediaPipe's landmarks against MANO21's joints: wrist; thumb CMC, MCP, IP -> MANO thumb1-3; each
// other finger's MCP, PIP, DIP -> MANO's three joints of that finger; the five tips -> tips.
constexpr std::array<int, 21> kMano21FromMediaPipe = {0,  5,  6,  7,  9,  10, 11, 17, 18, 19, 13,
                                                      14, 15, 1,  2,  3,  4,  8,  12, 16, 20};

}  // namespace handscs
