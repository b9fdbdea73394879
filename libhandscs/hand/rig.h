// The hand rig: everything LBS needs (MANO layout), for MANO converted from the user's pickle and for
// the built-in procedural hand alike. File format: docs/RIG_FORMAT.md (JSON, metres).
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include <torch/types.h>

namespace handscs {

constexpr int kRigJoints = 16;     // MANO joints: wrist + 5 fingers x 3
constexpr int kJoints21 = 21;      // MANO21: 16 rig joints, then tips thumb, index, middle, ring, pinky
constexpr int kPoseDim = 48;       // axis-angle: global orientation + 15 joints x 3
constexpr int kShapeDim = 10;      // shape blend shapes (beta)
constexpr int kPoseFeatureDim = 135;  // 15 joints x (R - I) flattened: pose blend shape input

enum class Handedness { right, left };
inline Handedness other_hand(Handedness side) {
  return side == Handedness::right ? Handedness::left : Handedness::right;
}

struct Rig {
  std::string name;                        // "builtin" or e.g. "MANO_RIGHT"
  Handedness handedness = Handedness::right;
  torch::Tensor v_template;   // [V, 3] float64, metres, canonical (zero-pose) vertices
  torch::Tensor faces;        // [F, 3] int64, counter-clockwise seen from outside
  torch::Tensor weights;      // [V, 16] float64 skinning weights, rows sum to 1
  torch::Tensor j_regressor;  // [16, V] float64, rows sum to 1
  std::vector<int64_t> parents;  // [16], parents[0] = -1, MANO joint order (docs/RIG_FORMAT.md)
  torch::Tensor posedirs;     // [V, 3, 135] float64 pose blend shapes
  torch::Tensor shapedirs;    // [V, 3, 10] float64 shape blend shapes
  torch::Tensor hands_mean;   // [45] float64 mean finger pose (added when flat_hand_mean = false)
  std::array<int64_t, 5> tip_vertices{};  // thumb, index, middle, ring, pinky tip vertex ids
  torch::Tensor vertex_labels;  // [V] int64 region label (0 skin, 1 nail, ...) or undefined

  int64_t num_vertices() const { return v_template.size(0); }
};

// Reads a rig file; errors name the file and key.
Rig load_rig(const std::string& path);
// Writes a rig file atomically.
void save_rig(const Rig& rig, const std::string& path);
// "builtin" (or "builtin:left") gives the procedural hand, "builtin+fingers" (or
// "builtin+fingers:left") the same with per-finger length modes (hand/finger_length_modes.h);
// anything else is a rig file path.
Rig load_rig_source(const std::string& source);

}  // namespace handscs
