#include "data/mesh_mask.h"

#include <algorithm>
#include <cmath>

#include "data/mesh_raster.h"

namespace handscs {

cv::Mat mesh_mask(const float* vertices, int64_t num_vertices, const int64_t* faces,
                  int64_t num_faces, const Camera& camera) {
  cv::Mat mask(camera.height, camera.width, CV_8UC1, cv::Scalar(0));
  // Rasterise only the projected bounding box: the rest of the image cannot be covered.
  const PixelRect bounds = projected_bounds(vertices, num_vertices, camera);
  if (bounds.empty()) return mask;
  MeshRaster raster;
  rasterize_mesh(vertices, num_vertices, faces, num_faces, camera, bounds, false, raster);
  const PixelRect& r = raster.rect;
  for (int y = r.y0; y < r.y1; ++y) {
    uint8_t* row = mask.ptr<uint8_t>(y);
    const int32_t* face = raster.face.data() + static_cast<size_t>(y - r.y0) * r.width();
    for (int x = r.x0; x < r.x1; ++x) row[x] = face[x - r.x0] >= 0 ? 1 : 0;
  }
  return mask;
}

PixelRect projected_bounds(const float* vertices, int64_t num_vertices, const Camera& camera) {
  double min_x = INFINITY, min_y = INFINITY, max_x = -INFINITY, max_y = -INFINITY;
  bool behind = false, in_front = false;
  for (int64_t v = 0; v < num_vertices; ++v) {
    const auto c = camera.to_camera({vertices[v * 3], vertices[v * 3 + 1], vertices[v * 3 + 2]});
    if (!(c[2] >= camera.near_plane)) {
      behind = true;  // a vertex behind the near plane: its triangles may span the whole image
      continue;
    }
    in_front = true;
    const auto uv = camera.project_camera(c);
    min_x = std::min(min_x, uv[0]);
    max_x = std::max(max_x, uv[0]);
    min_y = std::min(min_y, uv[1]);
    max_y = std::max(max_y, uv[1]);
  }
  if (!in_front) return PixelRect{};  // the whole mesh is behind the camera
  if (behind) return PixelRect{0, 0, camera.width, camera.height};
  if (!(min_x <= max_x && min_y <= max_y)) return PixelRect{};
  PixelRect r;
  // Pixels whose centre can lie inside: floor(min - 0.5) .. ceil(max - 0.5), plus one for safety.
  r.x0 = static_cast<int>(std::max(0.0, std::floor(min_x - 0.5)));
  r.y0 = static_cast<int>(std::max(0.0, std::floor(min_y - 0.5)));
  r.x1 = static_cast<int>(std::min<double>(camera.width, std::ceil(max_x + 0.5) + 1));
  r.y1 = static_cast<int>(std::min<double>(camera.height, std::ceil(max_y + 0.5) + 1));
  if (r.x1 <= r.x0 || r.y1 <= r.y0) return PixelRect{};
  return r;
}

}  // namespace handscs
