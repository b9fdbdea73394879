#include "metrics/region_means.h"

#include <ATen/ATen.h>

namespace handscs {

std::vector<std::optional<double>> region_means(const torch::Tensor& map, const torch::Tensor& regions) {
  TORCH_CHECK(map.dim() == 3, "region_means: map must be [C, h, w], got ", map.sizes());
  TORCH_CHECK(regions.dim() == 3 && regions.scalar_type() == at::kBool,
              "region_means: regions must be [R, H, W] bool, got ", regions.sizes(), " ",
              regions.scalar_type());
  const int64_t h = map.size(1), w = map.size(2), height = regions.size(1), width = regions.size(2);
  TORCH_CHECK(h <= height && w <= width && (height - h) % 2 == 0 && (width - w) % 2 == 0,
              "region_means: a ", h, "x", w, " map cannot be centred on ", height, "x", width, " regions");
  // Sum over channels first: the region weight is the same for every channel.
  const auto channel_sum = map.to(at::kDouble).sum(0);  // [h, w]
  const auto inside = regions.narrow(1, (height - h) / 2, h).narrow(2, (width - w) / 2, w);
  std::vector<std::optional<double>> means;
  for (int64_t r = 0; r < regions.size(0); ++r) {
    const auto plane = inside[r];
    const int64_t pixels = plane.sum().item<int64_t>();
    if (pixels == 0) {
      means.emplace_back();
      continue;
    }
    const double sum = channel_sum.masked_select(plane).sum().item<double>();
    means.emplace_back(sum / (static_cast<double>(pixels) * static_cast<double>(map.size(0))));
  }
  return means;
}

std::vector<int64_t> region_pixel_counts(const torch::Tensor& regions) {
  TORCH_CHECK(regions.dim() == 3 && regions.scalar_type() == at::kBool,
              "region_pixel_counts: regions must be [R, H, W] bool, got ", regions.sizes());
  const auto counts = regions.sum({1, 2}).to(at::kLong).contiguous();
  return std::vector<int64_t>(counts.data_ptr<int64_t>(), counts.data_ptr<int64_t>() + counts.numel());
}

}  // namespace handscs
