// Rotation matrices of quaternions, one home for the rasterizer's covariances and the avatar.
#pragma once

#include <torch/types.h>

namespace handscs {

// Rotation matrices [..., 3, 3] of quaternions [..., 4] (w, x, y, z), normalised here. |q|^2 is
// floored at 1e-24 (|q| >= 1e-12), so q = 0 gives the identity instead of 0/0. Differentiable.
torch::Tensor quaternion_to_matrix(const torch::Tensor& quats);

}  // namespace handscs
