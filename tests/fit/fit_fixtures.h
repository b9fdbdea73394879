// Test scenes for the fit module: a ring of cameras around the origin and hands of the built-in rig
// seen by them, projected with chosen noise.
#pragma once

#include <cmath>
#include <random>
#include <vector>

#include "core/camera.h"
#include "core/vec3.h"
#include "fit/multiview_hands.h"
#include "hand/joint_model.h"
#include "hand/so3.h"

namespace handscs::test {

// n cameras on a circle of radius 1 m about the y axis (and alternately 0.3 m above and below),
// each looking at the origin; 1280 x 1024 pixels, focal 1800 px (a ~40 degree field of view).
inline std::vector<Camera> camera_ring(int n) {
  std::vector<Camera> cameras;
  for (int i = 0; i < n; ++i) {
    const double a = 2.0 * M_PI * i / n;
    const Vec3 centre{std::sin(a), i % 2 ? 0.3 : -0.3, std::cos(a)};
    const Vec3 forward = normalized(centre * -1.0);
    const Vec3 right = normalized(cross(Vec3{0, -1, 0}, forward));
    const Vec3 down = cross(forward, right);
    Camera c;
    c.K = {1800, 0, 640, 0, 1800, 512, 0, 0, 1};
    c.R = {right[0], right[1], right[2], down[0], down[1], down[2], forward[0], forward[1], forward[2]};
    const Vec3 t = mat_vec(c.R, centre) * -1.0;
    c.t = {t[0], t[1], t[2]};
    c.width = 1280;
    c.height = 1024;
    cameras.push_back(c);
  }
  return cameras;
}

// The detection of MANO21 joints [63] in view `view`, with Gaussian pixel noise.
inline Detection project_hand(const std::vector<Camera>& cameras, int view, const double* joints, double noise_px,
                              std::mt19937& rng, const std::string& label) {
  std::normal_distribution<double> n(0.0, noise_px);
  Detection d;
  d.view = view;
  d.label = label;
  for (int j = 0; j < 21; ++j) {
    const auto uv = cameras[view].project_camera(cameras[view].to_camera({joints[3 * j], joints[3 * j + 1], joints[3 * j + 2]}));
    d.pixels[j] = {uv[0] + n(rng), uv[1] + n(rng)};
    d.valid[j] = 1;
  }
  return d;
}

}  // namespace handscs::test
