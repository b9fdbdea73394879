// Rotation matrices of quaternions, one home for the rasterizer's covariances and the avatar.
#pragma once

#include <torch/types.h>

namespace handscs {

// |q|^2 is floored here (|q| >= 1e-12), so q = 0 gives the identity instead of 0/0.
constexpr double kQuaternionNormSquaredFloor = 1e-24;

// Rotation matrices [..., 3, 3] of quaternions [..., 4] (w, x, y, z), normalised here.
// Differentiable.
torch::Tensor quaternion_to_matrix(const torch::Tensor& quats);

}  // namespace handscs
