// Rotation matrices of quaternions, one home for the rasterizer's covariances and the avatar.
#pragma once

#include <algorithm>
#include <cmath>

#include <torch/types.h>

namespace handscs {

// |q|^2 is floored here (|q| >= 1e-12), so q = 0 gives the identity instead of 0/0.
constexpr double kQuaternionNormSquaredFloor = 1e-24;

// Rotation matrices [..., 3, 3] of quaternions [..., 4] (w, x, y, z), normalised here.
// Differentiable.
torch::Tensor quaternion_to_matrix(const torch::Tensor& quats);

// The same for one quaternion, in plain arithmetic (loops over Gaussians without autograd).
template <class T>
void quaternion_to_matrix(T w, T x, T y, T z, T (&r)[3][3]) {
  const T norm = std::sqrt(std::max<T>(w * w + x * x + y * y + z * z, T(kQuaternionNormSquaredFloor)));
  w /= norm;
  x /= norm;
  y /= norm;
  z /= norm;
  r[0][0] = 1 - 2 * (y * y + z * z);
  r[0][1] = 2 * (x * y - w * z);
  r[0][2] = 2 * (x * z + w * y);
  r[1][0] = 2 * (x * y + w * z);
  r[1][1] = 1 - 2 * (x * x + z * z);
  r[1][2] = 2 * (y * z - w * x);
  r[2][0] = 2 * (x * z - w * y);
  r[2][1] = 2 * (y * z + w * x);
  r[2][2] = 1 - 2 * (x * x + y * y);
}

}  // namespace handscs
