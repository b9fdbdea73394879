// covariance_from_scale_rotation (declared in render/rasterize.h):
//   Sigma = R(q) diag(s)^2 R(q)^T, returned as the upper triangle (xx, xy, xz, yy, yz, zz); plain torch ops.
#include <torch/types.h>

#include "render/rasterize.h"
#include "render/rotation.h"

namespace handscs {

torch::Tensor covariance_from_scale_rotation(const torch::Tensor& scales, const torch::Tensor& quats) {
  TORCH_CHECK(scales.dim() == 2 && scales.size(1) == 3, "covariance_from_scale_rotation: scales must be [N, 3], got ",
              scales.sizes());
  TORCH_CHECK(quats.dim() == 2 && quats.size(1) == 4 && quats.size(0) == scales.size(0),
              "covariance_from_scale_rotation: quats must be [", scales.size(0), ", 4], got ", quats.sizes());
  TORCH_CHECK(scales.scalar_type() == quats.scalar_type(),
              "covariance_from_scale_rotation: scales and quats must share a dtype, got ", scales.scalar_type(),
              " and ", quats.scalar_type());
  const auto rot = quaternion_to_matrix(quats);  // [N, 3, 3]
  const auto m = rot * scales.unsqueeze(1);  // R diag(s): column k scaled by s_k
  const auto sigma = torch::matmul(m, m.transpose(1, 2));
  return torch::stack({sigma.select(1, 0).select(1, 0), sigma.select(1, 0).select(1, 1),
                       sigma.select(1, 0).select(1, 2), sigma.select(1, 1).select(1, 1),
                       sigma.select(1, 1).select(1, 2), sigma.select(1, 2).select(1, 2)},
                      1);
}

}  // namespace handscs
