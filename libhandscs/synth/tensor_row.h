// Row i of a contiguous [N, 3] float64 tensor as a Vec3: the generator's geometry is computed in
// doubles on rig tensors (one home for hand_axes, skin and tissue).
#pragma once

#include <cstdint>

#include <torch/types.h>

#include "synth/math.h"

namespace handscs::synth {

inline Vec3 tensor_row(const torch::Tensor& t, int64_t i) {
  const double* p = t[i].data_ptr<double>();
  return {p[0], p[1], p[2]};
}

}  // namespace handscs::synth
