#include "render/raster_frame.h"

#include <cmath>

#include <c10/util/Exception.h>

#include "render/rasterize.h"

namespace handscs {

namespace {

// 1.3x the half field of view: the limit the reference rasterizers clamp x/z, y/z to in the EWA Jacobian.
constexpr double kJacobianClampScale = 1.3;

bool all_finite(const double* v, int n) {
  for (int i = 0; i < n; ++i)
    if (!std::isfinite(v[i])) return false;
  return true;
}

}  // namespace

RasterFrame make_raster_frame(const Camera& camera, const RasterSettings& settings) {
  TORCH_CHECK(camera.width > 0 && camera.height > 0, "rasterize_gaussians: camera size must be positive, got ",
              camera.width, "x", camera.height);
  TORCH_CHECK(all_finite(camera.K.data(), 9) && all_finite(camera.R.data(), 9) && all_finite(camera.t.data(), 3),
              "rasterize_gaussians: camera K, R, t must be finite");
  const auto& K = camera.K;
  TORCH_CHECK(K[1] == 0 && K[3] == 0 && K[6] == 0 && K[7] == 0 && K[8] == 1,
              "rasterize_gaussians: camera K must be [[fx, 0, cx], [0, fy, cy], [0, 0, 1]], got [[", K[0], ", ",
              K[1], ", ", K[2], "], [", K[3], ", ", K[4], ", ", K[5], "], [", K[6], ", ", K[7], ", ", K[8], "]]");
  TORCH_CHECK(K[0] > 0 && K[4] > 0, "rasterize_gaussians: camera fx, fy must be positive, got ", K[0], ", ", K[4]);
  TORCH_CHECK(std::isfinite(camera.near_plane) && camera.near_plane > 0 && camera.far_plane > camera.near_plane,
              "rasterize_gaussians: need 0 < near_plane < far_plane, got ", camera.near_plane, ", ",
              camera.far_plane);
  for (int c = 0; c < 3; ++c)
    TORCH_CHECK(std::isfinite(settings.background[c]), "rasterize_gaussians: background must be finite");

  RasterFrame f;
  f.R = camera.R;
  f.t = camera.t;
  f.fx = K[0];
  f.fy = K[4];
  f.cx = K[2];
  f.cy = K[5];
  f.near_plane = camera.near_plane;
  f.far_plane = camera.far_plane;
  const double half_u = 0.5 * camera.width / f.fx, mid_u = (0.5 * camera.width - f.cx) / f.fx;
  const double half_v = 0.5 * camera.height / f.fy, mid_v = (0.5 * camera.height - f.cy) / f.fy;
  f.u_lo = mid_u - kJacobianClampScale * half_u;
  f.u_hi = mid_u + kJacobianClampScale * half_u;
  f.v_lo = mid_v - kJacobianClampScale * half_v;
  f.v_hi = mid_v + kJacobianClampScale * half_v;

  const PixelRect& roi = settings.roi;
  if (roi.empty()) {
    f.x0 = f.y0 = 0;
    f.width = camera.width;
    f.height = camera.height;
  } else {
    TORCH_CHECK(roi.x0 >= 0 && roi.y0 >= 0 && roi.x1 <= camera.width && roi.y1 <= camera.height,
                "rasterize_gaussians: roi [", roi.x0, ", ", roi.x1, ") x [", roi.y0, ", ", roi.y1,
                ") is not inside the ", camera.width, "x", camera.height, " image");
    f.x0 = roi.x0;
    f.y0 = roi.y0;
    f.width = roi.width();
    f.height = roi.height();
  }
  f.tiles_x = (f.width + kTileSize - 1) / kTileSize;
  f.tiles_y = (f.height + kTileSize - 1) / kTileSize;
  for (int c = 0; c < 3; ++c) f.background[c] = settings.background[c];
  return f;
}

}  // namespace handscs
