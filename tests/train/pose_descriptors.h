// Test fixture: the structural descriptors of an untrained built-in-hand avatar at two random poses
// (seeded), the query and reference sets of an inter-pose correspondence search.
#pragma once

#include <utility>

#include <torch/types.h>

#include "avatar/avatar.h"

namespace handscs_test {

inline std::pair<torch::Tensor, torch::Tensor> two_pose_descriptors(handscs::Avatar& avatar) {
  torch::NoGradGuard no_grad;
  torch::manual_seed(5);
  const auto shape = torch::zeros({10}), trans = torch::zeros({3});
  const auto a = avatar.pose(torch::randn({48}) * 0.3, shape, trans, true).descriptor;
  const auto b = avatar.pose(torch::randn({48}) * 0.3, shape, trans, true).descriptor;
  return {a, b};
}

}  // namespace handscs_test
