#include "metrics/lpips_spatial.h"

#include <ATen/ATen.h>

namespace handscs {

torch::Tensor upsample_mean_preserving(const torch::Tensor& map, int64_t height, int64_t width) {
  TORCH_CHECK(map.dim() == 4, "upsample_mean_preserving: expected [B, C, h, w], got ", map.sizes());
  const int64_t h = map.size(2), w = map.size(3);
  TORCH_CHECK(h >= 1 && w >= 1 && h <= height && w <= width, "upsample_mean_preserving: map ", h, "x",
              w, " cannot be upsampled to ", height, "x", width);
  const std::vector<int64_t> in_size = {1, 1, h, w}, out_size = {height, width};
  // U^T 1: how much of the upsampled image each cell feeds (the adjoint of U applied to ones).
  // Upsampling never skips a cell, so every weight is positive.
  const auto feed = at::upsample_bilinear2d_backward(
      at::ones({1, 1, height, width}, map.options()), out_size, in_size,
      /*align_corners=*/false);
  const auto weight = feed * (static_cast<double>(h * w) / static_cast<double>(height * width));
  return at::upsample_bilinear2d(map / weight, out_size, /*align_corners=*/false);
}

torch::Tensor lpips_map_from_layers(const std::vector<torch::Tensor>& layers, int64_t height,
                                    int64_t width) {
  TORCH_CHECK(!layers.empty(), "lpips_map_from_layers: no layers");
  torch::Tensor total;
  for (const auto& layer : layers) {
    const auto up = upsample_mean_preserving(layer, height, width);
    total = total.defined() ? total + up : up;
  }
  return total;
}

torch::Tensor lpips_distance_map(const Lpips& lpips, const torch::Tensor& x, const torch::Tensor& y) {
  return lpips_map_from_layers(lpips.layer_distances(x, y), x.size(2), x.size(3));
}

}  // namespace handscs
