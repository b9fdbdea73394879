// Separable 2-D filter with zero padding (the Gaussian blur inside SSIM), differentiable.
// out[b,c,i,j] = sum_{k,l} taps[k] taps[l] in_pad[b,c,i+k,j+l], in_pad = input with `pad` zeros on each side.
#pragma once

#include <cstdint>

#include <torch/types.h>

namespace handscs {

// Normalised 1-D Gaussian taps g[k] ~ exp(-(k - size/2)^2 / (2 sigma^2)), sum 1 (computed in double).
torch::Tensor gaussian_taps(int64_t size, double sigma, torch::Dtype dtype);  // -> [size]

// Applies `taps` along W, then along H, of every [H, W] plane. pad = (K-1)/2 keeps the size
// ("same", zero padding); pad = 0 keeps only windows fully inside the image ("valid").
// Output [B, C, H + 2 pad - K + 1, W + 2 pad - K + 1]. Differentiable in `input` (not in `taps`).
torch::Tensor separable_blur(const torch::Tensor& input,  // [B, C, H, W] float or double
                             const torch::Tensor& taps,   // [K], same dtype as input
                             int64_t pad);                // 0 <= pad <= K - 1

}  // namespace handscs
