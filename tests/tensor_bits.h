// Bit-for-bit comparison of floating-point tensors for tests of kernels that promise another form's
// values (SIMD passes against plain loops, one-pass ops against LibTorch's). NaNs are compared by
// place only: which NaN (sign, payload) an operation with NaN operands returns depends on the
// operand order the compiler picks, also between two scalar builds, and LibTorch's own bf16 cast
// writes 0x7FC0 or 0xFFFF depending on the vector position.
#pragma once

#include <torch/types.h>

namespace handscs_test {

// Same sizes and dtype (float, double or bfloat16), the same bits wherever a is not NaN, and NaN
// in the same places.
inline bool same_bits(const torch::Tensor& a, const torch::Tensor& b) {
  if (a.sizes() != b.sizes() || a.scalar_type() != b.scalar_type()) return false;
  const auto type = a.scalar_type();
  const auto as_int = type == torch::kFloat    ? torch::kInt32
                      : type == torch::kDouble ? torch::kInt64
                      : type == torch::kBFloat16 ? torch::kInt16
                                                 : torch::kBool;
  if (as_int == torch::kBool) return false;  // not a type this compares
  const auto nan_a = torch::isnan(a), nan_b = torch::isnan(b);
  if (!nan_a.equal(nan_b)) return false;
  const auto bits = [&](const torch::Tensor& t, const torch::Tensor& nan) {
    return t.masked_fill(nan, 0).contiguous().view(as_int);
  };
  return bits(a, nan_a).equal(bits(b, nan_b));
}

}  // namespace handscs_test
