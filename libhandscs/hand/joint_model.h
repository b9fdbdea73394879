// The 21 MANO21 joints of a rig as a function of its parameters, with their exact Jacobian, in plain
// double loops (the keypoint fit evaluates it thousands of times a frame; lbs() would skin every
// vertex through ~150 LibTorch ops). The same skinning as hand/lbs.h, restricted to what the joints
// need: rest joints J(beta) = J_reg (T + S beta); the 16 posed joints o_k from the chain
// G_k = G_parent [R_k | J_k - J_parent]; each tip x = sum_k w_k (Rg_k (u - J_k) + o_k) with
// u = T_tip + S_tip beta + P_tip (R - I) its shaped and pose-blended rest vertex.
// Parameters: absolute axis-angles (hands_mean already added), translation, shape.
#pragma once

#include <array>
#include <cstdint>

#include "hand/rig.h"

namespace handscs {

// Columns of the Jacobian: 48 axis-angle values, then 3 translation, then 10 shape coefficients.
constexpr int kJointParams = kPoseDim + 3 + kShapeDim;  // 61
constexpr int kTransColumn = kPoseDim;                  // 48
constexpr int kShapeColumn = kPoseDim + 3;              // 51

struct JointModel {
  Handedness handedness = Handedness::right;
  std::array<int64_t, kRigJoints> parents{};
  std::array<double, kRigJoints * 3> rest_joints{};                // J_reg T  [16][3]
  std::array<double, kRigJoints * 3 * kShapeDim> joint_shapedirs{};  // J_reg S  [16][3][10]
  std::array<double, 5 * 3> tip_template{};                        // T at the tips [5][3]
  std::array<double, 5 * 3 * kShapeDim> tip_shapedirs{};           // [5][3][10]
  std::array<double, 5 * 3 * kPoseFeatureDim> tip_posedirs{};      // [5][3][135]
  std::array<double, 5 * kRigJoints> tip_weights{};                // [5][16]
  std::array<double, kPoseDim - 3> hands_mean{};                   // [45]
  // Unit rest direction of each joint's child bone (the next joint, or the tip), canonical frame;
  // zero for the wrist.
  std::array<double, kRigJoints * 3> child_axis{};
};

JointModel make_joint_model(const Rig& rig);

struct JointParams {
  std::array<double, kPoseDim> pose{};   // absolute axis-angle per joint (no hands_mean offset)
  std::array<double, 3> trans{};         // metres, added after skinning
  std::array<double, kShapeDim> shape{};
};

// joints [21 * 3] (MANO21, metres); jacobian, when not null, [63 * 61] row-major.
void joint_positions(const JointModel& model, const JointParams& params, double* joints,
                     double* jacobian = nullptr);

}  // namespace handscs
