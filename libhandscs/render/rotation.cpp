#include "render/rotation.h"

#include <torch/types.h>

namespace handscs {

torch::Tensor quaternion_to_matrix(const torch::Tensor& quats) {
  const auto q = quats / (quats * quats).sum(-1, true).clamp_min(kQuaternionNormSquaredFloor).sqrt();
  const auto w = q.select(-1, 0), x = q.select(-1, 1), y = q.select(-1, 2), z = q.select(-1, 3);
  const auto m = torch::stack({1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y),
                               2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
                               2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)},
                              -1);
  auto sizes = quats.sizes().vec();
  sizes.back() = 3;
  sizes.push_back(3);
  return m.view(sizes);
}

}  // namespace handscs
