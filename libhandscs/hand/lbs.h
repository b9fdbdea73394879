// Differentiable batched linear blend skinning (MANO):
//   v_shaped = T + S beta, J = J_reg v_shaped, v_posed = v_shaped + P (R(theta) - I),
//   G_k = prod along the chain of [R_k | J_k - J_parent], A_k = G_k with rest joint removed,
//   v = sum_k w_k A_k v_posed + trans.
#pragma once

#include <torch/types.h>

#include "hand/rig.h"

namespace handscs {

struct LbsOptions {
  bool flat_hand_mean = false;  // false: pose[3:48] is relative to rig.hands_mean (InterHand/MANO)
};

struct LbsOutput {
  torch::Tensor vertices;           // [B, V, 3] posed vertices (world, translation applied)
  torch::Tensor joints;             // [B, 21, 3] posed joints in MANO21 order (tips from vertices)
  torch::Tensor rest_joints;        // [B, 21, 3] canonical joints of the shaped zero-pose hand
  torch::Tensor joint_transforms;   // [B, 16, 4, 4] A_k: maps canonical (rest) points to world
  torch::Tensor blend_offsets;      // [B, V, 3] shape + pose blend offsets added before skinning
  torch::Tensor shape_offsets;      // [B, V, 3] shape blend offsets alone (v_shaped - template)
  torch::Tensor vertex_transforms;  // [B, V, 4, 4] sum_k w_vk A_k
};

// pose [B, 48] axis-angle, shape [B, 10], trans [B, 3]; dtype of the outputs follows pose's dtype.
LbsOutput lbs(const Rig& rig, const torch::Tensor& pose, const torch::Tensor& shape,
              const torch::Tensor& trans, const LbsOptions& options = {});

// Axis-angle [..., 3] -> rotation matrices [..., 3, 3]; finite value and gradient at zero angle.
torch::Tensor rodrigues(const torch::Tensor& axis_angle);

// MANO21 -> InterHand2.6M joint order (per hand): ih[i] = mano21[kInterHandFromMano21[i]].
constexpr std::array<int, 21> kInterHandFromMano21 = {16, 15, 14, 13, 17, 3, 2, 1, 18, 6, 5,
                                                      4,  19, 12, 11, 10, 20, 9, 8, 7, 0};

}  // namespace handscs
