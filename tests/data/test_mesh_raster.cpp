// Mesh rasteriser against an independent reference (per-pixel ray casting, Moller-Trumbore in
// double): visible face, depth and barycentrics; plus the pixel-centre convention, watertightness
// (every pixel of a tiled plane claimed exactly once) and near-plane clipping.
#include <cmath>
#include <random>

#include "data/camera_transforms.h"
#include "data/mesh_mask.h"
#include "data/mesh_raster.h"

// Catch last: LibTorch pulls in glog, whose CHECK macro would otherwise replace Catch's.
#include <catch2/catch.hpp>

using namespace handscs;

namespace {

Camera test_camera(int width, int height, double f, double cx, double cy) {
  Camera camera;
  camera.K = {f, 0, cx, 0, f, cy, 0, 0, 1};
  camera.width = width;
  camera.height = height;
  return camera;
}

struct Hit {
  int face = -1;
  double t = INFINITY;
  double bary[3] = {0, 0, 0};
  double edge = 0;  // smallest barycentric: how close the ray passes to an edge
};

// Nearest hit of the ray through pixel centre (x + .5, y + .5) among triangles with z in
// [near, far]; camera-space vertices.
Hit cast_ray(const std::vector<double>& cam, const std::vector<int64_t>& faces,
             const Camera& camera, int x, int y, double* second_t) {
  const double d[3] = {(x + 0.5 - camera.cx()) / camera.fx(), (y + 0.5 - camera.cy()) / camera.fy(),
                       1.0};
  Hit best;
  *second_t = INFINITY;
  for (size_t f = 0; f < faces.size() / 3; ++f) {
    const double* a = &cam[faces[f * 3] * 3];
    const double* b = &cam[faces[f * 3 + 1] * 3];
    const double* c = &cam[faces[f * 3 + 2] * 3];
    double e1[3], e2[3], p[3], q[3], s[3];
    for (int k = 0; k < 3; ++k) {
      e1[k] = b[k] - a[k];
      e2[k] = c[k] - a[k];
      s[k] = -a[k];
    }
    p[0] = d[1] * e2[2] - d[2] * e2[1];
    p[1] = d[2] * e2[0] - d[0] * e2[2];
    p[2] = d[0] * e2[1] - d[1] * e2[0];
    const double det = e1[0] * p[0] + e1[1] * p[1] + e1[2] * p[2];
    if (std::fabs(det) < 1e-14) continue;
    const double u = (s[0] * p[0] + s[1] * p[1] + s[2] * p[2]) / det;
    q[0] = s[1] * e1[2] - s[2] * e1[1];
    q[1] = s[2] * e1[0] - s[0] * e1[2];
    q[2] = s[0] * e1[1] - s[1] * e1[0];
    const double v = (d[0] * q[0] + d[1] * q[1] + d[2] * q[2]) / det;
    const double t = (e2[0] * q[0] + e2[1] * q[1] + e2[2] * q[2]) / det;
    const double w = 1 - u - v;
    if (u < 0 || v < 0 || w < 0) continue;
    if (t < camera.near_plane || t > camera.far_plane) continue;  // d.z = 1: t is the depth
    if (t < best.t) {
      *second_t = best.t;
      best.face = static_cast<int>(f);
      best.t = t;
      best.bary[0] = w;
      best.bary[1] = u;
      best.bary[2] = v;
      best.edge = std::min({u, v, w});
    } else if (t < *second_t) {
      *second_t = t;
    }
  }
  return best;
}

}  // namespace

TEST_CASE("mesh raster: pixel centres at (i + 0.5, j + 0.5)") {
  // A square spanning u, v in [1, 3] at depth 2 covers exactly pixels 1..2 x 1..2.
  const Camera camera = test_camera(5, 5, 4.0, 0.0, 0.0);
  const float z = 2.0f;
  // u = 4 X / 2 => X = u / 2.
  const std::vector<float> vertices = {0.5f, 0.5f, z, 1.5f, 0.5f, z, 1.5f, 1.5f, z, 0.5f, 1.5f, z};
  const std::vector<int64_t> faces = {0, 1, 2, 0, 2, 3};
  const cv::Mat mask = mesh_mask(vertices.data(), 4, faces.data(), 2, camera);
  for (int y = 0; y < 5; ++y)
    for (int x = 0; x < 5; ++x) {
      INFO(x << "," << y);
      CHECK(mask.at<uint8_t>(y, x) == ((x == 1 || x == 2) && (y == 1 || y == 2) ? 1 : 0));
    }
  // Shifting the square by +0.4 px keeps the same pixels; +0.6 px moves them by one.
  std::vector<float> shifted = vertices;
  for (int v = 0; v < 4; ++v) shifted[v * 3] += 0.4f / 2.0f;
  CHECK(mesh_mask(shifted.data(), 4, faces.data(), 2, camera).at<uint8_t>(1, 1) == 1);
  for (int v = 0; v < 4; ++v) shifted[v * 3] += 0.2f / 2.0f;
  const cv::Mat moved = mesh_mask(shifted.data(), 4, faces.data(), 2, camera);
  CHECK(moved.at<uint8_t>(1, 1) == 0);
  CHECK(moved.at<uint8_t>(1, 3) == 1);
}

TEST_CASE("mesh raster: a tiled plane covers every pixel exactly once (top-left rule)") {
  // Grid vertices project to u, v = 2k + 0.5: shared edges pass exactly through pixel centres.
  const Camera camera = test_camera(24, 20, 8.0, 0.5, 0.5);
  const int n = 10;  // (n+1)^2 vertices at X, Y = k / 4 (exact in binary), Z = 1
  std::vector<float> vertices;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) {
      vertices.push_back(i * 0.25f);
      vertices.push_back(j * 0.25f);
      vertices.push_back(1.0f);
    }
  std::vector<int64_t> faces;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const int64_t a = j * (n + 1) + i, b = a + 1, c = a + n + 1, d = c + 1;
      // Alternate the diagonal and the winding to exercise both orientations.
      if ((i + j) % 2) {
        faces.insert(faces.end(), {a, b, d, a, d, c});
      } else {
        faces.insert(faces.end(), {a, c, b, b, c, d});
      }
    }
  std::vector<int> claims(camera.width * camera.height, 0);
  for (size_t f = 0; f < faces.size() / 3; ++f) {
    MeshRaster one;
    rasterize_mesh(vertices.data(), static_cast<int64_t>(vertices.size() / 3), faces.data() + f * 3,
                   1, camera, PixelRect{}, false, one);
    for (int y = 0; y < camera.height; ++y)
      for (int x = 0; x < camera.width; ++x) claims[y * camera.width + x] += one.covered(x, y);
  }
  // The plane spans u, v in [0.5, 20.5]: centres 0.5 .. 20.5 fall on or inside its border; the
  // top-left rule keeps the top and left border (u or v = 0.5) and drops the bottom and right.
  for (int y = 0; y < camera.height; ++y)
    for (int x = 0; x < camera.width; ++x) {
      const bool inside = x < 20 && y < 20;
      INFO(x << "," << y);
      CHECK(claims[y * camera.width + x] == (inside ? 1 : 0));
    }
}

TEST_CASE("mesh raster: agrees with per-pixel ray casting on random scenes (with near clipping)") {
  std::mt19937 rng(1234);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  int compared = 0, ambiguous = 0, scenes_with_clipping = 0;
  for (int scene = 0; scene < 40; ++scene) {
    Camera camera = test_camera(48, 36, 40.0, 23.7, 18.2);
    camera.near_plane = 0.3;
    camera.far_plane = 6.0;
    const int num_triangles = 1 + scene % 12;
    std::vector<float> vertices;
    std::vector<int64_t> faces;
    bool clipped = false;
    for (int t = 0; t < num_triangles; ++t) {
      const double cx = uniform(rng) * 0.8, cy = uniform(rng) * 0.6, cz = 1.5 + uniform(rng);
      for (int k = 0; k < 3; ++k) {
        const double z = cz + uniform(rng) * 1.4;  // some vertices fall behind the near plane
        clipped = clipped || z < camera.near_plane;
        vertices.push_back(static_cast<float>(cx + uniform(rng) * 0.7));
        vertices.push_back(static_cast<float>(cy + uniform(rng) * 0.7));
        vertices.push_back(static_cast<float>(z));
        faces.push_back(t * 3 + k);
      }
    }
    scenes_with_clipping += clipped;
    MeshRaster raster;
    rasterize_mesh(vertices.data(), static_cast<int64_t>(vertices.size() / 3), faces.data(),
                   num_triangles, camera, PixelRect{}, true, raster);
    std::vector<double> cam(vertices.begin(), vertices.end());  // identity camera pose
    for (int y = 0; y < camera.height; ++y)
      for (int x = 0; x < camera.width; ++x) {
        double second_t = 0;
        const Hit hit = cast_ray(cam, faces, camera, x, y, &second_t);
        const size_t i = static_cast<size_t>(y) * camera.width + x;
        // Pixels whose ray grazes an edge, or two surfaces within float precision, are ambiguous.
        if ((hit.face >= 0 && hit.edge < 1e-6) || std::fabs(second_t - hit.t) < 1e-5 * hit.t) {
          ++ambiguous;
          continue;
        }
        INFO("scene " << scene << " pixel " << x << "," << y);
        REQUIRE(raster.face[i] == hit.face);
        if (hit.face < 0) continue;
        CHECK(raster.depth[i] == Approx(hit.t).epsilon(1e-5));
        for (int k = 0; k < 3; ++k)
          CHECK(raster.bary[i * 3 + k] == Approx(hit.bary[k]).margin(2e-5));
        ++compared;
      }
  }
  CHECK(compared > 10000);
  CHECK(scenes_with_clipping > 10);
  CHECK(ambiguous < 200);
}

TEST_CASE(
    "mesh raster: ROI rasterises a sub-rectangle identically and a scaled camera sub-samples") {
  const Camera camera = test_camera(40, 30, 50.0, 20.0, 15.0);
  const std::vector<float> vertices = {-0.2f, -0.15f, 1.0f, 0.25f, -0.1f, 1.2f, 0.0f, 0.2f, 0.9f};
  const std::vector<int64_t> faces = {0, 1, 2};
  MeshRaster full, part;
  rasterize_mesh(vertices.data(), 3, faces.data(), 1, camera, PixelRect{}, false, full);
  const PixelRect rect{5, 4, 31, 22};
  rasterize_mesh(vertices.data(), 3, faces.data(), 1, camera, rect, false, part);
  CHECK(part.width() == 26);
  CHECK(part.height() == 18);
  for (int y = rect.y0; y < rect.y1; ++y)
    for (int x = rect.x0; x < rect.x1; ++x) CHECK(part.covered(x, y) == full.covered(x, y));
  // 3x resolution: the centre sub-pixel of each pixel is the pixel centre itself.
  MeshRaster fine;
  rasterize_mesh(vertices.data(), 3, faces.data(), 1, scale_camera(camera, 3), PixelRect{}, false,
                 fine);
  for (int y = 0; y < camera.height; ++y)
    for (int x = 0; x < camera.width; ++x)
      CHECK(fine.covered(3 * x + 1, 3 * y + 1) == full.covered(x, y));
  // Bad face ids and non-finite vertices are skipped, not read.
  const std::vector<int64_t> bad = {0, 1, 7};
  MeshRaster none;
  rasterize_mesh(vertices.data(), 3, bad.data(), 1, camera, PixelRect{}, false, none);
  for (int32_t f : none.face) CHECK(f == -1);
  std::vector<float> nan_vertices = vertices;
  nan_vertices[4] = NAN;
  rasterize_mesh(nan_vertices.data(), 3, faces.data(), 1, camera, PixelRect{}, false, none);
  for (int32_t f : none.face) CHECK(f == -1);
}

TEST_CASE("mesh raster: projected bounds contain the mask") {
  const Camera camera = test_camera(40, 30, 50.0, 20.0, 15.0);
  const std::vector<float> vertices = {-0.2f, -0.15f, 1.0f, 0.25f, -0.1f, 1.2f, 0.0f, 0.2f, 0.9f};
  const std::vector<int64_t> faces = {0, 1, 2};
  const PixelRect bounds = projected_bounds(vertices.data(), 3, camera);
  const cv::Mat mask = mesh_mask(vertices.data(), 3, faces.data(), 1, camera);
  int inside = 0;
  for (int y = 0; y < 30; ++y)
    for (int x = 0; x < 40; ++x)
      if (mask.at<uint8_t>(y, x)) {
        CHECK(x >= bounds.x0);
        CHECK(x < bounds.x1);
        CHECK(y >= bounds.y0);
        CHECK(y < bounds.y1);
        ++inside;
      }
  CHECK(inside > 50);
  std::vector<float> away = vertices;
  for (int v = 0; v < 3; ++v) away[v * 3] += 5.0f;  // far off to the right
  CHECK(projected_bounds(away.data(), 3, camera).empty());
}
