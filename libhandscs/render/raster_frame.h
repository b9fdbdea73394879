// The geometry of one rasterizer call in plain numbers (camera, render region, 16x16 tile grid), shared by the
// raw kernels. Region-local pixel (i, j) is image pixel (x0 + i, y0 + j), sampled at image (x0 + i + .5, y0 + j + .5).
#pragma once

#include <array>
#include <cstdint>

#include "core/camera.h"

namespace handscs {

struct RasterSettings;

constexpr int kTileSize = 16;  // 16x16 pixel tiles: one tile row is 16 float lanes (one AVX-512 register)

struct RasterFrame {
  std::array<double, 9> R{};  // world -> camera rotation, row-major
  std::array<double, 3> t{};
  double fx = 1, fy = 1, cx = 0, cy = 0;
  double near_plane = 0.01, far_plane = 100.0;
  // EWA Jacobian clamp of x/z and y/z: 1.3x the image's half extent around the image centre, as the reference
  // rasterizers do, so Gaussians far outside the view do not get a huge, meaningless Jacobian.
  double u_lo = 0, u_hi = 0, v_lo = 0, v_hi = 0;
  int x0 = 0, y0 = 0;           // region origin in image pixels
  int width = 0, height = 0;    // region size (= output size)
  int tiles_x = 0, tiles_y = 0;
  std::array<double, 3> background{0, 0, 0};

  int num_tiles() const { return tiles_x * tiles_y; }
  int64_t num_pixels() const { return int64_t(width) * height; }
};

// Validates the camera (finite, positive focal lengths, zero skew, 0 < near < far, positive size) and the ROI
// (inside the image); throws c10::Error naming the bad value.
RasterFrame make_raster_frame(const Camera& camera, const RasterSettings& settings);

}  // namespace handscs
