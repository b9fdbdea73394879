// A decoder's hidden layer in bf16, relu(x W^T + b), as a GEMM without bias followed by one pass
// that adds the bias and applies the ReLU in place: faster than addmm, which fills its output with
// the bias and has oneDNN add the product to it (a "sum" post-op), then relu_. The sum is taken in
// float from the GEMM's bf16 output, so the result is rounded twice where addmm rounds once (one
// bf16 unit apart in 10-15% of the entries; docs/BENCHMARKS.md#model-forward-and-backward).
#pragma once

#include <torch/types.h>

namespace handscs {

// In place, not recorded by autograd: y = bf16(max(float(y) + bias, 0)), NaN kept (as LibTorch's
// relu; -0 becomes +0), rounded to nearest even with NaN as 0x7FC0 (c10::BFloat16's conversion).
// y: [N, M] bf16, contiguous, not requiring grad while grad mode is on.
// bias: float [M] (one per column) or bf16 [N, M] (one per entry), contiguous.
void add_bias_relu_(torch::Tensor& y, const torch::Tensor& bias);

// relu(x weight^T + bias) with its own backward (once differentiable: no double backward).
// x: [N, K] bf16. weight: [M, K] bf16. bias: [M] float. Returns [N, M] bf16.
// The backward's ReLU mask (a gradient passes where the output is > 0 or NaN, as LibTorch's
// threshold_backward) and the bias gradient (summed in float, in a fixed order: the same for any
// thread count) are one pass; the weight and input gradients are the GEMMs of LibTorch's mm backward.
torch::Tensor linear_relu(const torch::Tensor& x, const torch::Tensor& weight, const torch::Tensor& bias);

}  // namespace handscs
