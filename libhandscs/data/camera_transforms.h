// Cameras derived from a capture camera: a crop (principal point shifted by the crop origin) and a
// uniform resampling (K scaled, so pixel (i, j) of the scaled image is sampled at (i+.5, j+.5)/s).
#pragma once

#include "core/camera.h"

namespace handscs {

// Camera of the sub-image `rect`: cx -= x0, cy -= y0, size = rect size.
inline Camera crop_camera(const Camera& camera, const PixelRect& rect) {
  Camera out = camera;
  out.K[2] -= rect.x0;
  out.K[5] -= rect.y0;
  out.width = rect.width();
  out.height = rect.height();
  return out;
}

// Camera of the same view resampled to width x height at `scale` times the resolution: u' = scale u
// (K's focal lengths and principal point scaled; pixel centres stay at i + 0.5).
inline Camera resample_camera(const Camera& camera, double scale, int width, int height) {
  Camera out = camera;
  for (int i : {0, 1, 2, 4, 5}) out.K[i] *= scale;
  out.width = width;
  out.height = height;
  return out;
}

// The same at an integer `scale`: with an odd one the centre sub-pixel of pixel (i, j) sits exactly
// at (i + 0.5, j + 0.5) of the original image.
inline Camera scale_camera(const Camera& camera, int scale) {
  return resample_camera(camera, scale, camera.width * scale, camera.height * scale);
}

}  // namespace handscs
