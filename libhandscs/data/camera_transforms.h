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

// Camera of the same view at `scale` times the resolution: u' = scale u. With an odd integer scale
// the centre sub-pixel of pixel (i, j) sits exactly at (i + 0.5, j + 0.5) of the original image.
inline Camera scale_camera(const Camera& camera, int scale) {
  Camera out = camera;
  out.K[0] *= scale;
  out.K[1] *= scale;
  out.K[2] *= scale;
  out.K[4] *= scale;
  out.K[5] *= scale;
  out.width = camera.width * scale;
  out.height = camera.height * scale;
  return out;
}

}  // namespace handscs
