#include "data/mesh_raster.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace handscs {

namespace {

struct ScreenVertex {
  double x, y;     // pixel coordinates (continuous)
  double inv_z;    // 1 / camera z
  double bary[3];  // barycentrics of this vertex w.r.t. the original triangle (clipping)
};

struct CameraVertex {
  double p[3];
  double bary[3];
};

// Edge function of a->b at p, computed from the lexicographically smaller end point so that the two
// triangles sharing an edge get exactly opposite values (watertight: no pixel lost or doubled).
inline double edge_function(const ScreenVertex& a, const ScreenVertex& b, double px, double py) {
  const bool a_first = a.x < b.x || (a.x == b.x && a.y < b.y);
  const ScreenVertex& s = a_first ? a : b;
  const ScreenVertex& e = a_first ? b : a;
  const double value = (e.x - s.x) * (py - s.y) - (e.y - s.y) * (px - s.x);
  return a_first ? value : -value;
}

// Top-left rule for a positively oriented triangle (see edge_function's sign) in y-down pixels.
inline bool owns_ties(const ScreenVertex& a, const ScreenVertex& b) {
  const double dx = b.x - a.x, dy = b.y - a.y;
  return dy < 0 || (dy == 0 && dx > 0);
}

inline bool inside(double w, bool tie) { return w > 0 || (w == 0 && tie); }

void raster_triangle(ScreenVertex v0, ScreenVertex v1, ScreenVertex v2, int32_t face_id,
                     const Camera& camera, bool want_bary, MeshRaster& out) {
  double area = edge_function(v0, v1, v2.x, v2.y);
  if (!(std::fabs(area) > 0) || !std::isfinite(area)) return;  // degenerate or non-finite
  if (area < 0) {
    std::swap(v1, v2);
    area = -area;
  }
  const PixelRect& r = out.rect;
  const double min_x = std::min({v0.x, v1.x, v2.x}), max_x = std::max({v0.x, v1.x, v2.x});
  const double min_y = std::min({v0.y, v1.y, v2.y}), max_y = std::max({v0.y, v1.y, v2.y});
  // Pixel i is sampled at i + 0.5: the covered columns are ceil(min - 0.5) .. floor(max - 0.5).
  const double lo_x = std::max<double>(r.x0, std::ceil(min_x - 0.5));
  const double hi_x = std::min<double>(r.x1 - 1, std::floor(max_x - 0.5));
  const double lo_y = std::max<double>(r.y0, std::ceil(min_y - 0.5));
  const double hi_y = std::min<double>(r.y1 - 1, std::floor(max_y - 0.5));
  if (!(lo_x <= hi_x && lo_y <= hi_y)) return;
  const bool tie0 = owns_ties(v1, v2), tie1 = owns_ties(v2, v0), tie2 = owns_ties(v0, v1);
  const double inv_area = 1.0 / area;
  const double far_plane = camera.far_plane;
  const int w = r.width();
  for (int y = static_cast<int>(lo_y); y <= static_cast<int>(hi_y); ++y) {
    const double py = y + 0.5;
    for (int x = static_cast<int>(lo_x); x <= static_cast<int>(hi_x); ++x) {
      const double px = x + 0.5;
      const double w0 = edge_function(v1, v2, px, py);
      if (!inside(w0, tie0)) continue;
      const double w1 = edge_function(v2, v0, px, py);
      if (!inside(w1, tie1)) continue;
      const double w2 = edge_function(v0, v1, px, py);
      if (!inside(w2, tie2)) continue;
      const double l0 = w0 * inv_area, l1 = w1 * inv_area, l2 = w2 * inv_area;
      const double inv_z = l0 * v0.inv_z + l1 * v1.inv_z + l2 * v2.inv_z;
      if (!(inv_z > 0)) continue;
      const double z = 1.0 / inv_z;
      if (!(z <= far_plane)) continue;
      const size_t index = static_cast<size_t>(y - r.y0) * w + (x - r.x0);
      if (!(z < out.depth[index])) continue;
      out.depth[index] = static_cast<float>(z);
      out.face[index] = face_id;
      if (want_bary) {
        const double p0 = l0 * v0.inv_z * z, p1 = l1 * v1.inv_z * z, p2 = l2 * v2.inv_z * z;
        for (int k = 0; k < 3; ++k)
          out.bary[index * 3 + k] =
              static_cast<float>(p0 * v0.bary[k] + p1 * v1.bary[k] + p2 * v2.bary[k]);
      }
    }
  }
}

ScreenVertex project(const CameraVertex& c, const Camera& camera) {
  ScreenVertex s;
  s.inv_z = 1.0 / c.p[2];
  s.x = camera.fx() * c.p[0] * s.inv_z + camera.cx();
  s.y = camera.fy() * c.p[1] * s.inv_z + camera.cy();
  for (int k = 0; k < 3; ++k) s.bary[k] = c.bary[k];
  return s;
}

// Sutherland-Hodgman clip of a triangle against z >= near; returns the polygon size (0, 3 or 4).
int clip_near(const CameraVertex in[3], double near_plane, CameraVertex out[4]) {
  int n = 0;
  for (int k = 0; k < 3; ++k) {
    const CameraVertex& a = in[k];
    const CameraVertex& b = in[(k + 1) % 3];
    const bool a_in = a.p[2] >= near_plane, b_in = b.p[2] >= near_plane;
    if (a_in) out[n++] = a;
    if (a_in != b_in) {
      const double s = (near_plane - a.p[2]) / (b.p[2] - a.p[2]);
      CameraVertex m;
      for (int d = 0; d < 3; ++d) {
        m.p[d] = a.p[d] + s * (b.p[d] - a.p[d]);
        m.bary[d] = a.bary[d] + s * (b.bary[d] - a.bary[d]);
      }
      m.p[2] = near_plane;
      out[n++] = m;
    }
  }
  return n;
}

}  // namespace

void rasterize_mesh(const float* vertices, int64_t num_vertices, const int64_t* faces,
                    int64_t num_faces, const Camera& camera, const PixelRect& rect, bool want_bary,
                    MeshRaster& out) {
  PixelRect r = rect.empty() ? PixelRect{0, 0, camera.width, camera.height} : rect;
  r.x0 = std::max(r.x0, 0);
  r.y0 = std::max(r.y0, 0);
  r.x1 = std::min(r.x1, camera.width);
  r.y1 = std::min(r.y1, camera.height);
  if (r.x1 < r.x0) r.x1 = r.x0;
  if (r.y1 < r.y0) r.y1 = r.y0;
  out.rect = r;
  const size_t count = static_cast<size_t>(r.width()) * r.height();
  out.face.assign(count, -1);
  out.depth.assign(count, std::numeric_limits<float>::infinity());
  if (want_bary) {
    out.bary.assign(count * 3, 0.0f);
  } else {
    out.bary.clear();
  }
  if (count == 0) return;

  std::vector<double> cam(static_cast<size_t>(num_vertices) * 3);
  for (int64_t v = 0; v < num_vertices; ++v) {
    const std::array<double, 3> p = {vertices[v * 3], vertices[v * 3 + 1], vertices[v * 3 + 2]};
    const std::array<double, 3> c = camera.to_camera(p);
    for (int d = 0; d < 3; ++d) cam[v * 3 + d] = c[d];
  }
  const double near_plane = camera.near_plane;
  for (int64_t f = 0; f < num_faces; ++f) {
    CameraVertex tri[3];
    bool ok = true;
    for (int k = 0; k < 3 && ok; ++k) {
      const int64_t id = faces[f * 3 + k];
      if (id < 0 || id >= num_vertices) {
        ok = false;
        break;
      }
      for (int d = 0; d < 3; ++d) {
        tri[k].p[d] = cam[id * 3 + d];
        tri[k].bary[d] = d == k ? 1.0 : 0.0;
        ok = ok && std::isfinite(tri[k].p[d]);
      }
    }
    if (!ok) continue;
    const int32_t face_id = static_cast<int32_t>(f);
    if (tri[0].p[2] >= near_plane && tri[1].p[2] >= near_plane && tri[2].p[2] >= near_plane) {
      raster_triangle(project(tri[0], camera), project(tri[1], camera), project(tri[2], camera),
                      face_id, camera, want_bary, out);
      continue;
    }
    CameraVertex poly[4];
    const int n = clip_near(tri, near_plane, poly);
    for (int k = 1; k + 1 < n; ++k)
      raster_triangle(project(poly[0], camera), project(poly[k], camera),
                      project(poly[k + 1], camera), face_id, camera, want_bary, out);
  }
}

}  // namespace handscs
