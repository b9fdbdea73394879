// 2-D max pooling without autograd, for LPIPS's backbones at evaluation: LibTorch 1.13
// runs at::max_pool2d through max_pool2d_with_indices on the CPU even when no gradient is wanted,
// ~4.3 ms of every 512x334 LPIPS score (two AlexNet pools). A maximum has no rounding, so this
// gives at::max_pool2d's values, NaN propagation included (tests/metrics/test_max_pool.cpp); only
// the sign of a zero maximum may differ where a window holds both -0 and +0 (ties are taken in
// another order), which no later operation can tell apart.
#pragma once

#include <torch/types.h>

namespace handscs {

// x: [B, C, H, W] float or double; square window `kernel`, `stride`, no padding, floor mode (the
// defaults of at::max_pool2d with these two arguments). Returns [B, C, (H - k) / s + 1, (W - k) / s + 1].
torch::Tensor max_pool_2d(const torch::Tensor& x,  // [B, C, H, W] on the CPU
                          int64_t kernel, int64_t stride);

// at::max_pool2d when x needs a gradient, max_pool_2d otherwise.
torch::Tensor max_pool_2d_any(const torch::Tensor& x, int64_t kernel, int64_t stride);

}  // namespace handscs
