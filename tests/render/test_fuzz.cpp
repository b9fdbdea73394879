// Seeded fuzz test: 2,000 small random scenes (image 1-40 px a side, 0-12 Gaussians, random cameras, depths from
// behind the camera through the near plane to 3 m, scales 1e-4-1 m with some degenerate axes, opacities including
// 0, 1 and > 1, colours outside [0, 1], occasional NaN/Inf entries, random backgrounds, ROIs and depth output).
// Every scene must give finite outputs and gradients in float and double, and agree with the dense reference:
// double kernel vs double reference, every scene (image 1e-9, VJP 1e-6 relative); float kernel vs the double
// reference on the same float inputs (image 1e-4, VJP 1e-3) in all but 0.5% of the scenes, where a float alpha or
// transmittance within rounding of a threshold may flip. The float bounds are looser than the 1e-5 / 1e-4 of the
// ordinary-scene agreement test because these scenes include near-plane and 1e4:1 anisotropic Gaussians and
// random-sign cotangents whose float gradient sums cancel by 1e3. (The float reference is not the oracle for
// float: its float projection of thin covariances is itself inaccurate; the kernel projects in double.)
#include "catch_torch.h"  // first: torch, minus glog's CHECK, then Catch2

#include <limits>

#include "render/reference.h"
#include "render_test_util.h"

using namespace handscs;
using namespace handscs::test;

namespace {

struct FuzzScene {
  torch::Tensor means, covs, colors, opacities;  // double
  Camera cam;
  RasterSettings settings;
};

FuzzScene make_scene(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> U(0.0, 1.0);
  std::normal_distribution<double> N01(0.0, 1.0);
  auto uniform_int = [&](int lo, int hi) { return lo + int(U(rng) * (hi - lo + 1) * 0.999999); };
  FuzzScene s;
  s.cam = make_camera(uniform_int(1, 40), uniform_int(1, 40), 10 + 70 * U(rng), U(rng) < 0.7);
  s.cam.K[2] += 4 * N01(rng);
  s.cam.K[5] += 4 * N01(rng);
  const int n = uniform_int(0, 12);
  auto means = torch::empty({n, 3}, torch::kFloat64), scales = torch::empty({n, 3}, torch::kFloat64);
  auto quats = torch::empty({n, 4}, torch::kFloat64), colors = torch::empty({n, 3}, torch::kFloat64);
  auto opac = torch::empty({n}, torch::kFloat64);
  for (int i = 0; i < n; ++i) {
    double z = 0.05 + 2.95 * U(rng);
    const double r = U(rng);
    if (r < 0.05) z = -0.5 * U(rng);                        // behind
    else if (r < 0.1) z = s.cam.near_plane * (0.5 + U(rng));  // around the near plane
    const double u = s.cam.width * (1.4 * U(rng) - 0.2), v = s.cam.height * (1.4 * U(rng) - 0.2);
    const auto w = from_camera(s.cam, {(u - s.cam.cx()) / s.cam.fx() * z, (v - s.cam.cy()) / s.cam.fy() * z, z});
    for (int k = 0; k < 3; ++k) {
      means[i][k] = w[k];
      scales[i][k] = U(rng) < 0.05 ? 0.0 : std::pow(10.0, -4 + 4 * U(rng));
      colors[i][k] = -0.2 + 1.4 * U(rng);
    }
    for (int k = 0; k < 4; ++k) quats[i][k] = N01(rng);
    const double o = U(rng);
    opac[i] = o < 0.05 ? 0.0 : o < 0.1 ? 1.0 : o < 0.12 ? 1.5 : U(rng);
  }
  s.means = means;
  s.covs = covariance_from_scale_rotation(scales, quats);
  s.colors = colors;
  s.opacities = opac;
  if (n > 0 && U(rng) < 0.05) {  // poison one entry
    const double bad[] = {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity(),
                          -std::numeric_limits<double>::infinity()};
    const double value = bad[uniform_int(0, 2)];
    const int i = uniform_int(0, n - 1);
    switch (uniform_int(0, 3)) {
      case 0: s.means[i][uniform_int(0, 2)] = value; break;
      case 1: s.covs[i][uniform_int(0, 5)] = value; break;
      case 2: s.colors[i][uniform_int(0, 2)] = value; break;
      default: s.opacities[i] = value;
    }
  }
  for (int c = 0; c < 3; ++c) s.settings.background[c] = float(U(rng));
  s.settings.compute_depth = U(rng) < 0.5;
  if (U(rng) < 0.3) {
    const int x0 = uniform_int(0, s.cam.width - 1), y0 = uniform_int(0, s.cam.height - 1);
    s.settings.roi = PixelRect{x0, y0, uniform_int(x0 + 1, s.cam.width), uniform_int(y0 + 1, s.cam.height)};
  }
  return s;
}

struct Errors {
  double image = 0, grad = 0;
  bool finite = true;
};

Errors compare(const FuzzScene& s, torch::Dtype dtype, uint64_t seed, torch::Dtype ref_dtype) {
  const int64_t n = s.means.size(0);
  auto leaf = [&](const torch::Tensor& t) { return t.detach().to(dtype).clone().requires_grad_(true); };
  std::vector<torch::Tensor> kin = {leaf(s.means), leaf(s.covs), leaf(s.colors), leaf(s.opacities),
                                    leaf(torch::zeros({n, 2}, torch::kFloat64))};
  auto ref_leaf = [&](const torch::Tensor& t) {
    return t.detach().to(dtype).to(ref_dtype).clone().requires_grad_(true);
  };
  std::vector<torch::Tensor> rin = {ref_leaf(s.means), ref_leaf(s.covs), ref_leaf(s.colors), ref_leaf(s.opacities),
                                    ref_leaf(torch::zeros({n, 2}, torch::kFloat64))};
  const RasterOutput k = rasterize_gaussians(kin[0], kin[1], kin[2], kin[3], s.cam, s.settings, kin[4]);
  const RasterOutput r = rasterize_gaussians_reference(rin[0], rin[1], rin[2], rin[3], s.cam, s.settings, rin[4]);
  const auto w = random_weights(k.rgb.size(0), k.rgb.size(1), seed, dtype);
  loss_of(k, w).backward();
  loss_of(r, w.rgb.defined() ? LossWeights{w.rgb.to(ref_dtype), w.alpha.to(ref_dtype), w.depth.to(ref_dtype)} : w)
      .backward();
  Errors e;
  e.finite = all_finite(k.rgb) && all_finite(k.alpha) && all_finite(k.depth);
  e.image = std::max(max_abs(k.rgb, r.rgb), max_abs(k.alpha, r.alpha));
  for (int i = 0; i < 5; ++i) {
    e.finite = e.finite && all_finite(kin[i].grad());
    e.grad = std::max(e.grad, rel_err(kin[i].grad(), rin[i].grad(), 1e-6));

  }
  return e;
}

}  // namespace

TEST_CASE("fuzz: 2000 random small scenes are finite and agree with the reference") {
  const SingleThreadScope single_thread;
  std::mt19937_64 rng(20240601);
  constexpr int kScenes = 2000;
  int float_outliers = 0;
  Errors worst_double, worst_float;
  for (int scene = 0; scene < kScenes; ++scene) {
    const FuzzScene s = make_scene(rng);
    INFO("scene " << scene << ": " << s.cam.width << "x" << s.cam.height << ", " << s.means.size(0) << " Gaussians");
    const Errors d = compare(s, torch::kFloat64, scene, torch::kFloat64);
    REQUIRE(d.finite);
    CHECK(d.image <= 1e-9);
    CHECK(d.grad <= 1e-6);
    worst_double.image = std::max(worst_double.image, d.image);
    worst_double.grad = std::max(worst_double.grad, d.grad);
    const Errors f = compare(s, torch::kFloat32, scene, torch::kFloat64);
    REQUIRE(f.finite);
    if (f.image > 1e-4 || f.grad > 1e-3) ++float_outliers;
    worst_float.image = std::max(worst_float.image, f.image);
    worst_float.grad = std::max(worst_float.grad, f.grad);
  }
  WARN("fuzz over " << kScenes << " scenes: double max image error " << worst_double.image << ", max VJP error "
                    << worst_double.grad << "; float max image error " << worst_float.image << ", max VJP error "
                    << worst_float.grad << ", scenes beyond (1e-4, 1e-3): " << float_outliers);
  // A float alpha or transmittance that lands within rounding of 1/255, 0.99 or 1e-4 can flip a decision (two
  // capped 0.99 alphas give T = 1e-4 exactly, and opacities >= 1 are common here): allow 0.5% of the scenes.
  CHECK(float_outliers <= kScenes / 200);
}
