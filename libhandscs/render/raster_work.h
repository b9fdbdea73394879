// Work counters of one rasterizer call (for benchmarks and tuning): how many Gaussians survive culling, how many
// (tile, Gaussian) entries the binning makes and how many (pixel, Gaussian) pairs are actually blended.
#pragma once

#include <cstdint>

#include <torch/types.h>

#include "render/rasterize.h"

namespace handscs {

struct RasterWork {
  int64_t visible_gaussians = 0;   // radius > 0
  int64_t tile_entries = 0;        // (tile, Gaussian) pairs after binning
  int64_t contributing_pairs = 0;  // (pixel, Gaussian) pairs blended (alpha >= 1/255, before the T stop)
};

// Runs the forward kernels once (no autograd) and counts; same inputs and checks as rasterize_gaussians.
RasterWork measure_raster_work(const torch::Tensor& means,        // [N, 3]
                               const torch::Tensor& covariances,  // [N, 6]
                               const torch::Tensor& colors,       // [N, 3]
                               const torch::Tensor& opacities,    // [N]
                               const Camera& camera, const RasterSettings& settings);

}  // namespace handscs
