// One LPIPS tap's distance map without autograd, for evaluation: out = sum_c w_c (n(fx)_c - n(fy)_c)^2,
// n(f) = f / (|f|_c + 1e-10) with |f|_c = sqrt(sum_c f^2) where that sum is > 0, else 0.
//
// Why: Lpips::layer_distances' LibTorch form (unit_normalize_channels twice, sub, square, 1x1 conv)
// is ~10 kernels and ~10 passes over the features, ~3-4 ms of a ~34 ms 512x334 score.
// This is two passes over the channels: the squared norms of both sides, then the weighted squared
// difference, with per-pixel accumulators. Same formula and rounding steps in the features' dtype
// (divisions, not reciprocals; no FMA contraction in this library); only the order of the channel
// sums differs from LibTorch's reduction and the conv's GEMM, so the last bits may
// (tests/metrics/test_lpips_tap_distance.cpp). A NaN feature makes its pixel NaN, as there.
#pragma once

#include <torch/types.h>

namespace handscs {

// The tap's map [B, 1, H, W] in the features' dtype (float or double, CPU; never records a graph:
// callers use LibTorch's form when a gradient is wanted).
torch::Tensor lpips_tap_distance(const torch::Tensor& fx,    // [B, C, H, W]
                                 const torch::Tensor& fy,    // [B, C, H, W]
                                 const torch::Tensor& lin);  // [C], the tap's 1x1 lin weights

}  // namespace handscs
