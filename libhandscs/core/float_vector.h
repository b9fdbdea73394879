// Poses [48], shapes [10] and translations [3] as the avatar takes them: a 1-D float32 tensor that
// owns a copy of the values (the source array may go away before the tensor does).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

#include <torch/types.h>

namespace handscs {

inline torch::Tensor float_vector(const float* values, int64_t n) {
  return torch::from_blob(const_cast<float*>(values), {n}, torch::kFloat32).clone();
}

template <size_t N>
torch::Tensor float_vector(const std::array<float, N>& values) {
  return float_vector(values.data(), static_cast<int64_t>(N));
}

}  // namespace handscs
