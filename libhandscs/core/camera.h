// Pinhole camera shared by every module (OpenCV convention, metres): X_cam = R X_world + t,
// u = fx X/Z + cx, v = fy Y/Z + cy, x right, y down, z forward, no distortion.
//
// Pixel-centre convention (used by the splat rasterizer, the mesh rasterizer and the data reader
// alike): pixel (col i, row j) covers [i, i+1) x [j, j+1) in (u, v) and is sampled at its centre
// (i + 0.5, j + 0.5). InterHand2.6M's principal points are used as given.
#pragma once

#include <array>

namespace handscs {

struct Camera {
  std::array<double, 9> K{1, 0, 0, 0, 1, 0, 0, 0, 1};  // row-major 3x3 intrinsics
  std::array<double, 9> R{1, 0, 0, 0, 1, 0, 0, 0, 1};  // row-major world->camera rotation
  std::array<double, 3> t{0, 0, 0};                    // world->camera translation (m)
  int width = 0;
  int height = 0;
  double near_plane = 0.01;  // m: closer points are culled (a hand is never 1 cm from a lens)
  double far_plane = 100.0;  // m: farther points are culled

  double fx() const { return K[0]; }
  double fy() const { return K[4]; }
  double cx() const { return K[2]; }
  double cy() const { return K[5]; }

  // World point -> camera coordinates.
  std::array<double, 3> to_camera(const std::array<double, 3>& p) const {
    return {R[0] * p[0] + R[1] * p[1] + R[2] * p[2] + t[0],
            R[3] * p[0] + R[4] * p[1] + R[5] * p[2] + t[1],
            R[6] * p[0] + R[7] * p[1] + R[8] * p[2] + t[2]};
  }
  // Camera point -> continuous pixel coordinates (u, v); pixel (i, j) has its centre at (i+.5, j+.5).
  std::array<double, 2> project_camera(const std::array<double, 3>& c) const {
    return {fx() * c[0] / c[2] + cx(), fy() * c[1] / c[2] + cy()};
  }
  // Camera centre in world coordinates: -R^T t.
  std::array<double, 3> centre() const {
    return {-(R[0] * t[0] + R[3] * t[1] + R[6] * t[2]), -(R[1] * t[0] + R[4] * t[1] + R[7] * t[2]),
            -(R[2] * t[0] + R[5] * t[1] + R[8] * t[2])};
  }
};

// Pixel rectangle [x0, x1) x [y0, y1); an empty rectangle (x1 <= x0) means the whole image.
struct PixelRect {
  int x0 = 0, y0 = 0, x1 = 0, y1 = 0;
  bool empty() const { return x1 <= x0 || y1 <= y0; }
  int width() const { return x1 - x0; }
  int height() const { return y1 - y0; }
};

}  // namespace handscs
