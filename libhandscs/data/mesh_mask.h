// Hand mask of one view from the posed mesh: mask(i, j) = 1 when a triangle covers the pixel centre
// (i + 0.5, j + 0.5) (data/mesh_raster.h), else 0. Background pixels are 0.
#pragma once

#include <cstdint>
#include <opencv2/core/mat.hpp>

#include "core/camera.h"

namespace handscs {

// vertices [V, 3] float world (m), faces [F, 3]. Returns CV_8UC1 of camera.height x camera.width.
cv::Mat mesh_mask(const float* vertices, int64_t num_vertices, const int64_t* faces,
                  int64_t num_faces, const Camera& camera);

// Pixel bounding box of the projected vertices in front of the camera, clipped to the image: empty
// when none projects inside or all are behind the camera, the whole image when the mesh crosses the
// near plane. A cheap test of whether the hand is in view at all.
PixelRect projected_bounds(const float* vertices, int64_t num_vertices, const Camera& camera);

}  // namespace handscs
