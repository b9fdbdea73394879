// LPIPS as a distance map at image resolution, for scoring parts of an image (docs/METRICS.md):
// map(x) = sum_t (U_t (d_t / c_t))(x), U_t = bilinear upsampling (align_corners = false, as the
// official lpips spatial=True), c_t = U_t^T 1 * (h_t w_t) / (H W) its per-cell weight, normalised.
//
// Dividing by c_t makes every feature cell carry the same total weight over the image, so the
// plain mean of the map equals the scalar LPIPS (lpips_from_layers) up to float rounding; the
// official map's mean is not its scalar (per-cell weights in 0.998-1.006 on AlexNet's taps at
// 512x334). Each map pixel stays within those factors of the official map.
#pragma once

#include <cstdint>
#include <vector>

#include <torch/types.h>

#include "metrics/lpips.h"

namespace handscs {

// Bilinear upsampling to [B, C, H, W] whose per-input-cell weights are normalised as above:
// mean over H x W of the result equals the mean over h x w of `map`. Needs h <= H and w <= W.
torch::Tensor upsample_mean_preserving(const torch::Tensor& map,  // [B, C, h, w]
                                       int64_t height, int64_t width);

// The spatial LPIPS map [B, 1, H, W] from Lpips::layer_distances, at image size H x W.
torch::Tensor lpips_map_from_layers(const std::vector<torch::Tensor>& layers,  // [B, 1, h_t, w_t]
                                    int64_t height, int64_t width);

// lpips_map_from_layers(lpips.layer_distances(x, y), H, W): [B, 1, H, W].
torch::Tensor lpips_distance_map(const Lpips& lpips,
                                 const torch::Tensor& x,   // [B, 3, H, W], see input_range
                                 const torch::Tensor& y);  // [B, 3, H, W]

}  // namespace handscs
