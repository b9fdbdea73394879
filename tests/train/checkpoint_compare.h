// Two training checkpoints compared tensor by tensor: the largest difference of a floating-point
// tensor relative to max(scale_floor, its largest magnitude), and every integer tensor exactly.
#pragma once

#include <algorithm>
#include <functional>
#include <string>

#include <torch/types.h>

#include "run/checkpoint.h"

namespace handscs_test {

struct CheckpointDifference {
  double worst = 0;        // largest relative difference of a floating-point tensor
  std::string worst_name;  // ... and its name
  std::string mismatch;    // first tensor missing from a or differing in shape or integer values
};

// Compares the tensors of `b` (those `include` accepts; all without it) with those of `a`, which
// may hold more. scale_floor 1: absolute differences for tensors of magnitude below 1.
inline CheckpointDifference compare_checkpoints(
    const handscs::Checkpoint& a, const handscs::Checkpoint& b, double scale_floor = 1.0,
    const std::function<bool(const std::string&)>& include = {}) {
  CheckpointDifference d;
  for (const auto& [name, tensor] : b.tensors) {
    if (include && !include(name)) continue;
    const auto it = a.tensors.find(name);
    if (it == a.tensors.end() || it->second.sizes() != tensor.sizes()) {
      if (d.mismatch.empty()) d.mismatch = name;
      continue;
    }
    const auto& other = it->second;
    if (!tensor.is_floating_point()) {
      if (!torch::equal(tensor, other) && d.mismatch.empty()) d.mismatch = name;
      continue;
    }
    const double scale = std::max(scale_floor, other.abs().max().item<double>());
    const double diff =
        (tensor.to(torch::kFloat64) - other.to(torch::kFloat64)).abs().max().item<double>() / scale;
    if (diff > d.worst) d.worst = diff, d.worst_name = name;
  }
  return d;
}

}  // namespace handscs_test
