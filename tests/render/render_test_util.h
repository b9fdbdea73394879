// Shared fixtures for the rasterizer tests: seeded random scenes, cameras, scalar losses with fixed random
// weights, finite differences in double precision and error measures.
#pragma once

#include <cmath>
#include <cstdint>
#include <functional>
#include <random>
#include <vector>

#include <omp.h>
#include <torch/types.h>

#include "core/threads.h"
#include "render/rasterize.h"

namespace handscs::test {

struct Scene {
  torch::Tensor means, covs, colors, opacities;  // [N,3] [N,6] [N,3] [N]
  Camera camera;
};

struct SceneOptions {
  int num_gaussians = 20;
  int width = 32, height = 24;
  double focal = 40.0;                                // pixels
  double sigma_px_lo = 1.5, sigma_px_hi = 3.5;        // projected standard deviations
  double opacity_lo = 0.05, opacity_hi = 0.95;
  double color_lo = 0.0, color_hi = 1.0;
  double depth_lo = 0.9, depth_hi = 1.1;              // metres
  double margin_px = 2.0;                             // centres this far outside the image allowed
  bool rotated_camera = true;                         // non-identity R, t
  torch::Dtype dtype = torch::kFloat64;
};

// Rotation matrix from a unit quaternion (w, x, y, z), row-major.
inline std::array<double, 9> quat_to_matrix(double w, double x, double y, double z) {
  return {1 - 2 * (y * y + z * z), 2 * (x * y - w * z),     2 * (x * z + w * y),
          2 * (x * y + w * z),     1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
          2 * (x * z - w * y),     2 * (y * z + w * x),     1 - 2 * (x * x + y * y)};
}

inline Camera make_camera(int width, int height, double focal, bool rotated) {
  Camera cam;
  cam.width = width;
  cam.height = height;
  cam.K = {focal, 0, 0.5 * width + 0.37, 0, focal * 1.05, 0.5 * height - 0.21, 0, 0, 1};
  if (rotated) {
    const double n = std::sqrt(0.9 * 0.9 + 0.1 * 0.1 + 0.2 * 0.2 + 0.3 * 0.3);
    cam.R = quat_to_matrix(0.9 / n, 0.1 / n, -0.2 / n, 0.3 / n);
    cam.t = {0.05, -0.1, 0.3};
  }
  return cam;
}

// World point whose camera coordinates are pc.
inline std::array<double, 3> from_camera(const Camera& cam, const std::array<double, 3>& pc) {
  const double d[3] = {pc[0] - cam.t[0], pc[1] - cam.t[1], pc[2] - cam.t[2]};
  return {cam.R[0] * d[0] + cam.R[3] * d[1] + cam.R[6] * d[2], cam.R[1] * d[0] + cam.R[4] * d[1] + cam.R[7] * d[2],
          cam.R[2] * d[0] + cam.R[5] * d[1] + cam.R[8] * d[2]};
}

inline Scene random_scene(const SceneOptions& o, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  std::normal_distribution<double> N01(0.0, 1.0);
  Scene s;
  s.camera = make_camera(o.width, o.height, o.focal, o.rotated_camera);
  const int n = o.num_gaussians;
  auto means = torch::empty({n, 3}, torch::kFloat64), scales = torch::empty({n, 3}, torch::kFloat64);
  auto quats = torch::empty({n, 4}, torch::kFloat64), colors = torch::empty({n, 3}, torch::kFloat64);
  auto opac = torch::empty({n}, torch::kFloat64);
  const double fx = s.camera.fx(), fy = s.camera.fy(), cx = s.camera.cx(), cy = s.camera.cy();
  for (int i = 0; i < n; ++i) {
    const double z = o.depth_lo + (o.depth_hi - o.depth_lo) * U(rng);
    const double u = -o.margin_px + (o.width + 2 * o.margin_px) * U(rng);
    const double v = -o.margin_px + (o.height + 2 * o.margin_px) * U(rng);
    const auto w = from_camera(s.camera, {(u - cx) / fx * z, (v - cy) / fy * z, z});
    for (int k = 0; k < 3; ++k) {
      means[i][k] = w[k];
      scales[i][k] = (o.sigma_px_lo + (o.sigma_px_hi - o.sigma_px_lo) * U(rng)) * z / fx;
      colors[i][k] = o.color_lo + (o.color_hi - o.color_lo) * U(rng);
    }
    for (int k = 0; k < 4; ++k) quats[i][k] = N01(rng);
    opac[i] = o.opacity_lo + (o.opacity_hi - o.opacity_lo) * U(rng);
  }
  s.means = means.to(o.dtype);
  s.covs = covariance_from_scale_rotation(scales, quats).to(o.dtype);
  s.colors = colors.to(o.dtype);
  s.opacities = opac.to(o.dtype);
  return s;
}

// Fixed random weights for a scalar loss L = sum(w_rgb * rgb) + sum(w_a * alpha) (+ sum(w_d * depth)).
struct LossWeights {
  torch::Tensor rgb, alpha, depth;
};

inline LossWeights random_weights(int64_t h, int64_t w, uint64_t seed, torch::Dtype dtype) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  auto fill = [&](std::vector<int64_t> shape) {
    auto t = torch::empty(shape, torch::kFloat64);
    auto* p = t.data_ptr<double>();
    for (int64_t i = 0; i < t.numel(); ++i) p[i] = U(rng);
    return t.to(dtype);
  };
  return {fill({h, w, 3}), fill({h, w}), fill({h, w})};
}

inline torch::Tensor loss_of(const RasterOutput& out, const LossWeights& w) {
  auto loss = (out.rgb * w.rgb).sum() + (out.alpha * w.alpha).sum();
  if (out.depth.defined()) loss = loss + (out.depth * w.depth).sum() * 0.1;
  return loss;
}

// Max |a - b|.
inline double max_abs(const torch::Tensor& a, const torch::Tensor& b) {
  if (a.numel() == 0) return 0.0;
  return (a.to(torch::kFloat64) - b.to(torch::kFloat64)).abs().max().item<double>();
}

// |a - b| / max(|b|, floor) in the 2-norm: the relative error of a whole gradient tensor.
inline double rel_err(const torch::Tensor& a, const torch::Tensor& b, double floor = 1e-12) {
  const auto ad = a.to(torch::kFloat64), bd = b.to(torch::kFloat64);
  return (ad - bd).norm().item<double>() / std::max(bd.norm().item<double>(), floor);
}

inline bool all_finite(const torch::Tensor& t) { return !t.defined() || torch::isfinite(t).all().item<bool>(); }

// Numerics tests run on one thread (core/threads.h SingleThreadScope): the dense reference makes many
// small LibTorch calls, each of which may open an OpenMP region; on a loaded machine every region's
// barrier can cost a scheduler time slice (the FD test went from 0.8 s to 23 s with 2 threads under
// load). Thread-count independence of the kernel has its own test.
using handscs::SingleThreadScope;

}  // namespace handscs::test
