// Bit-for-bit comparison of float tensors for tests of SIMD passes that promise a plain loop's
// values. NaNs are compared by place only: which NaN (sign, payload) an operation with two NaN
// operands returns depends on the operand order the compiler picks, also between two scalar builds.
#pragma once

#include <torch/types.h>

namespace handscs_test {

// Same sizes, the same bits wherever a is not NaN, and NaN in the same places.
inline bool same_float_bits(const torch::Tensor& a, const torch::Tensor& b) {
  if (a.sizes() != b.sizes() || a.scalar_type() != torch::kFloat || b.scalar_type() != torch::kFloat) return false;
  const auto nan_a = torch::isnan(a), nan_b = torch::isnan(b);
  if (!nan_a.equal(nan_b)) return false;
  const auto bits = [](const torch::Tensor& t, const torch::Tensor& nan) {
    return t.contiguous().view(torch::kInt32).masked_fill(nan, 0);
  };
  return bits(a, nan_a).equal(bits(b, nan_b));
}

}  // namespace handscs_test
