// Means of a per-pixel metric map over the pixels of image regions (region PSNR / SSIM / LPIPS):
// mean_r = sum_{(i,j) in r, c} map[c, i, j] / (|r| C), r restricted to the pixels the map covers.
// A map smaller than the image (SSIM "valid"/"matlab": H-10 x W-10) is centred on it: map pixel
// (i, j) is image pixel (i + (H - h)/2, j + (W - w)/2), so region pixels in the border are left out.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include <torch/types.h>

namespace handscs {

// One value per region (double precision); empty where the region has no pixel inside the map.
std::vector<std::optional<double>> region_means(const torch::Tensor& map,       // [C, h, w]
                                                const torch::Tensor& regions);  // [R, H, W] bool

// Pixels per region: [R] int64.
std::vector<int64_t> region_pixel_counts(const torch::Tensor& regions);  // [R, H, W] bool

}  // namespace handscs
