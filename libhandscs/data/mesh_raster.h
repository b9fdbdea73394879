// Z-buffer triangle-mesh rasteriser (CPU, written here; not the splat renderer): for every pixel
// centre (i + 0.5, j + 0.5) of a rectangle it finds the nearest covering triangle, with depth
// z = 1 / sum_k(l_k / z_k) and perspective-correct barycentrics b_k = (l_k / z_k) z (l:
// screen-space).
//
// Conventions: core/camera.h (OpenCV pinhole, metres, pixel (i, j) sampled at (i + 0.5, j + 0.5)).
// Edges shared by two triangles belong to exactly one of them (top-left rule), so a closed mesh has
// neither gaps nor double coverage. Either winding is accepted (no back-face culling: masks need
// every surface). Triangles crossing the near plane are clipped against it; beyond the far plane
// they are dropped per pixel. Never throws; runs single-threaded (callers parallelise over images).
#pragma once

#include <cstdint>
#include <vector>

#include "core/camera.h"

namespace handscs {

struct MeshRaster {
  PixelRect rect;             // rasterised pixels [x0, x1) x [y0, y1) of the camera's image
  std::vector<int32_t> face;  // [h * w] covering triangle id, -1 = background (row-major in rect)
  std::vector<float> depth;   // [h * w] camera-space z (m) of the visible surface, +inf if none
  std::vector<float> bary;    // [h * w * 3] perspective-correct barycentrics (if requested)

  int width() const { return rect.width(); }
  int height() const { return rect.height(); }
  bool covered(int x, int y) const {
    return face[(y - rect.y0) * rect.width() + (x - rect.x0)] >= 0;
  }
};

// vertices: [V, 3] float world coordinates (m); faces: [F, 3] vertex ids (checked: ids outside
// [0, V) are skipped). rect: pixels to rasterise (empty = whole image; clipped to the image).
// want_bary = false skips the barycentric buffer (masks need only `face`).
void rasterize_mesh(const float* vertices, int64_t num_vertices, const int64_t* faces,
                    int64_t num_faces, const Camera& camera, const PixelRect& rect, bool want_bary,
                    MeshRaster& out);

}  // namespace handscs
