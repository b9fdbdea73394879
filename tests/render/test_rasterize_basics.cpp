// Closed-form checks (one Gaussian against the analytic EWA splat, the pixel-centre convention, radii, depth),
// ROI crops, determinism across thread counts and instruction sets, covariance_from_scale_rotation, the vector
// exp2, and input validation messages.
#include "catch_torch.h"  // first: torch, minus glog's CHECK, then Catch2

#include <cmath>
#include <string>

#include <omp.h>

#include "core/threads.h"
#include "render/composite.h"
#include "core/simd_level.h"
#include "render_test_util.h"
#include "test_support.h"

using namespace handscs;
using namespace handscs::test;

namespace {

// Camera with R = I, t = 0, fx = fy = f, principal point (cx, cy).
Camera plain_camera(int w, int h, double f, double cx, double cy) {
  Camera cam;
  cam.width = w;
  cam.height = h;
  cam.K = {f, 0, cx, 0, f, cy, 0, 0, 1};
  return cam;
}

torch::Tensor t64(std::vector<double> v, std::vector<int64_t> shape) {
  return torch::tensor(v, torch::kFloat64).view(shape);
}

// First line of the error f throws: torch's checks append a C++ backtrace after it.
std::string error_headline(const std::function<void()>& f) {
  const std::string m = handscs_test::error_of(f);
  return m.substr(0, m.find('\n'));
}

}  // namespace

TEST_CASE("one isotropic Gaussian matches the analytic EWA splat at pixel centres") {
  // Mean on the optical axis at depth 2, world sigma 0.05 m, f = 100: projected variance (100 * 0.05 / 2)^2 = 6.25
  // px^2, plus the 0.3 px^2 dilation. The principal point (10.5, 7.5) is the centre of pixel (10, 7).
  const Camera cam = plain_camera(24, 16, 100, 10.5, 7.5);
  const double o = 0.7, var = 6.25 + 0.3;
  const auto means = t64({0, 0, 2}, {1, 3}), covs = t64({0.0025, 0, 0, 0.0025, 0, 0.0025}, {1, 6});
  const auto colors = t64({0.2, 0.4, 0.9}, {1, 3}), opac = t64({o}, {1});
  RasterSettings settings;
  settings.background = {1.0f, 0.5f, 0.25f};
  settings.compute_depth = true;
  const RasterOutput out = rasterize_gaussians(means, covs, colors, opac, cam, settings);
  double worst = 0;
  for (int y = 0; y < 16; ++y)
    for (int x = 0; x < 24; ++x) {
      const double dx = x + 0.5 - 10.5, dy = y + 0.5 - 7.5;
      double a = o * std::exp(-0.5 * (dx * dx + dy * dy) / var);
      if (a < 1.0 / 255) a = 0;
      worst = std::max(worst, std::abs(out.alpha[y][x].item<double>() - a));
      worst = std::max(worst, std::abs(out.rgb[y][x][2].item<double>() - (0.9 * a + 0.25 * (1 - a))));
      if (a > 0) worst = std::max(worst, std::abs(out.depth[y][x].item<double>() - 2.0));
    }
  CHECK(worst < 1e-12);
  CHECK(out.alpha[7][10].item<double>() == Approx(o).epsilon(1e-14));  // exact centre: G = 1
  // Radius: the 1/255 contour, sqrt(2 ln(255 o) var) = 7.33 px -> 8.
  CHECK(out.radii[0].item<int>() == int(std::ceil(std::sqrt(2 * std::log(255 * o) * var))));
  // Symmetric about the centre pixel in both directions (the pixel-centre convention).
  CHECK(out.alpha[7][8].item<double>() == Approx(out.alpha[7][12].item<double>()).epsilon(1e-14));
  CHECK(out.alpha[5][10].item<double>() == Approx(out.alpha[9][10].item<double>()).epsilon(1e-14));
}

TEST_CASE("alpha cap, 1/255 skip and the transmittance stop behave as documented") {
  const Camera cam = plain_camera(8, 8, 100, 4.5, 4.5);
  RasterSettings settings;
  // Opacity 1 at the centre pixel: alpha capped at 0.99.
  auto out = rasterize_gaussians(t64({0, 0, 1}, {1, 3}), t64({1e-4, 0, 0, 1e-4, 0, 1e-4}, {1, 6}),
                                 t64({1, 1, 1}, {1, 3}), t64({1.0}, {1}), cam, settings);
  CHECK(out.alpha[4][4].item<double>() == Approx(0.99).epsilon(1e-14));
  // Opacity just below 1/255: culled (radius 0, nothing drawn).
  out = rasterize_gaussians(t64({0, 0, 1}, {1, 3}), t64({1e-4, 0, 0, 1e-4, 0, 1e-4}, {1, 6}), t64({1, 1, 1}, {1, 3}),
                            t64({0.999 / 255}, {1}), cam, settings);
  CHECK(out.radii[0].item<int>() == 0);
  CHECK(out.alpha.max().item<double>() == 0);
  // Three opaque Gaussians centred on pixel (4, 4), front to back red, green, blue, all alphas capped at 0.99:
  // T goes 1 -> 0.01 -> 1.0000000000000002e-4 (>= 1e-4: green is blended), and blue would take it to 1e-6 < 1e-4,
  // so blending stops before it.
  const auto tiny = std::vector<double>{1e-4, 0, 0, 1e-4, 0, 1e-4};
  std::vector<double> covs3;
  for (int i = 0; i < 3; ++i) covs3.insert(covs3.end(), tiny.begin(), tiny.end());
  out = rasterize_gaussians(t64({0, 0, 1, 0, 0, 1.1, 0, 0, 1.2}, {3, 3}), t64(covs3, {3, 6}),
                            t64({1, 0, 0, 0, 1, 0, 0, 0, 1}, {3, 3}), t64({1.0, 0.995, 1.0}, {3}), cam, settings);
  const double t1 = 1 - 0.99, t2 = t1 * (1 - 0.99);
  REQUIRE(t2 >= 1e-4);
  CHECK(out.rgb[4][4][0].item<double>() == Approx(0.99).epsilon(1e-12));
  CHECK(out.rgb[4][4][1].item<double>() == Approx(0.99 * t1).epsilon(1e-12));
  CHECK(out.rgb[4][4][2].item<double>() == 0);
  CHECK(out.alpha[4][4].item<double>() == Approx(1 - t2).epsilon(1e-12));
}

TEST_CASE("a ROI render is the crop of the full render, and its gradients those of the cropped loss") {
  SceneOptions o;
  o.num_gaussians = 60;
  o.width = 70;
  o.height = 50;
  o.focal = 60;
  o.dtype = torch::kFloat64;
  const Scene s = random_scene(o, 5);
  RasterSettings full, crop;
  full.compute_depth = crop.compute_depth = true;
  crop.roi = PixelRect{13, 9, 51, 41};
  auto m1 = s.means.clone().requires_grad_(true), m2 = s.means.clone().requires_grad_(true);
  auto c1 = s.covs.clone().requires_grad_(true), c2 = s.covs.clone().requires_grad_(true);
  const RasterOutput a = rasterize_gaussians(m1, c1, s.colors, s.opacities, s.camera, full);
  const RasterOutput b = rasterize_gaussians(m2, c2, s.colors, s.opacities, s.camera, crop);
  REQUIRE(b.rgb.sizes() == c10::IntArrayRef({32, 38, 3}));
  const auto ca = [&](const torch::Tensor& t) { return t.slice(0, 9, 41).slice(1, 13, 51); };
  CHECK(max_abs(ca(a.rgb), b.rgb) < 1e-12);
  CHECK(max_abs(ca(a.alpha), b.alpha) < 1e-12);
  CHECK(max_abs(ca(a.depth), b.depth) < 1e-10);
  const auto w = random_weights(32, 38, 8, torch::kFloat64);
  ((ca(a.rgb) * w.rgb).sum() + (ca(a.alpha) * w.alpha).sum()).backward();
  ((b.rgb * w.rgb).sum() + (b.alpha * w.alpha).sum()).backward();
  CHECK(rel_err(m2.grad(), m1.grad()) < 1e-10);
  CHECK(rel_err(c2.grad(), c1.grad()) < 1e-10);
  // Gaussians entirely outside the ROI are culled there.
  CHECK((b.radii > 0).sum().item<int64_t>() < (a.radii > 0).sum().item<int64_t>());
}

TEST_CASE("results do not depend on the thread count (bitwise)") {
  SceneOptions o;
  o.num_gaussians = 400;
  o.width = 100;
  o.height = 70;
  o.focal = 80;
  o.dtype = torch::kFloat32;
  const Scene s = random_scene(o, 6);
  RasterSettings settings;
  settings.compute_depth = true;
  std::vector<std::vector<torch::Tensor>> runs;
  const int before = omp_get_max_threads();
  for (int threads : {1, 2, 3}) {
    set_threads(threads);
    auto m = s.means.clone().requires_grad_(true), c = s.covs.clone().requires_grad_(true);
    auto col = s.colors.clone().requires_grad_(true), op = s.opacities.clone().requires_grad_(true);
    const RasterOutput out = rasterize_gaussians(m, c, col, op, s.camera, settings);
    loss_of(out, random_weights(70, 100, 1, torch::kFloat32)).backward();
    runs.push_back({out.rgb, out.alpha, out.depth, m.grad(), c.grad(), col.grad(), op.grad()});
  }
  set_threads(before);
  for (size_t r = 1; r < runs.size(); ++r)
    for (size_t k = 0; k < runs[0].size(); ++k) CHECK(torch::equal(runs[0][k], runs[r][k]));
}

TEST_CASE("every instruction set gives the same results (AVX2 and AVX-512 forward bitwise)") {
  SceneOptions o;
  o.num_gaussians = 300;
  o.width = 90;
  o.height = 60;
  o.focal = 80;
  o.dtype = torch::kFloat32;
  const Scene s = random_scene(o, 7);
  RasterSettings settings;
  settings.compute_depth = true;
  const SimdLevel detected = detected_simd_level();
  std::vector<std::pair<SimdLevel, std::vector<torch::Tensor>>> runs;
  for (SimdLevel level : {SimdLevel::generic, SimdLevel::avx2, SimdLevel::avx512}) {
    if (set_simd_level(level) != level) continue;  // not available on this CPU
    auto m = s.means.clone().requires_grad_(true), c = s.covs.clone().requires_grad_(true);
    const RasterOutput out = rasterize_gaussians(m, c, s.colors, s.opacities, s.camera, settings);
    loss_of(out, random_weights(60, 90, 2, torch::kFloat32)).backward();
    runs.push_back({level, {out.rgb, out.alpha, out.depth, m.grad(), c.grad()}});
  }
  set_simd_level(detected);
  REQUIRE(!runs.empty());
  for (size_t r = 1; r < runs.size(); ++r) {
    INFO("level " << simd_level_name(runs[r].first) << " vs " << simd_level_name(runs[0].first));
    for (int k = 0; k < 3; ++k) CHECK(max_abs(runs[r].second[k], runs[0].second[k]) < 1e-5);
    for (int k = 3; k < 5; ++k) CHECK(rel_err(runs[r].second[k], runs[0].second[k]) < 1e-4);
  }
  // AVX2 and AVX-512 share the FMA evaluation of alpha: identical forward images.
  if (runs.size() == 3)
    for (int k = 0; k < 3; ++k) CHECK(torch::equal(runs[1].second[k], runs[2].second[k]));
}

TEST_CASE("vector exp2 is accurate to 3e-7 relative at every instruction set") {
  std::vector<float> x, y;
  for (int i = 0; i <= 20000; ++i) x.push_back(-30.0f + 35.0f * float(i) / 20000.0f);
  y.resize(x.size());
  const SimdLevel detected = detected_simd_level();
  for (SimdLevel level : {SimdLevel::generic, SimdLevel::avx2, SimdLevel::avx512}) {
    if (set_simd_level(level) != level) continue;
    exp2_for_test(x.data(), y.data(), int(x.size()));
    double worst = 0;
    for (size_t i = 0; i < x.size(); ++i)
      worst = std::max(worst, std::abs(double(y[i]) / std::exp2(double(x[i])) - 1));
    INFO("level " << simd_level_name(level));
    CHECK(worst < 3e-7);
  }
  set_simd_level(detected);
  CHECK(simd_level_name(SimdLevel::avx2) == "avx2");
}

TEST_CASE("covariance_from_scale_rotation builds R diag(s)^2 R^T and survives q = 0") {
  const auto scales = t64({0.1, 0.2, 0.3, 1, 2, 3}, {2, 3});
  // 90 degrees about z: x -> y, y -> -x; unnormalised quaternion (scaled by 2).
  const auto quats = t64({2 * std::sqrt(0.5), 0, 0, 2 * std::sqrt(0.5), 0, 0, 0, 0}, {2, 4});
  const auto cov = covariance_from_scale_rotation(scales, quats);
  CHECK(max_abs(cov[0], t64({0.04, 0, 0, 0.01, 0, 0.09}, {6})) < 1e-15);
  CHECK(max_abs(cov[1], t64({1, 0, 0, 4, 0, 9}, {6})) < 1e-15);  // q = 0 -> identity
  auto q = quats.clone().requires_grad_(true);
  covariance_from_scale_rotation(scales, q).sum().backward();
  CHECK(all_finite(q.grad()));
  CHECK(error_headline([&] { covariance_from_scale_rotation(scales, quats.narrow(1, 0, 3)); }) ==
        "covariance_from_scale_rotation: quats must be [2, 4], got [2, 3]");
}

TEST_CASE("bad inputs are rejected with messages that name the argument and the sizes") {
  const Camera cam = plain_camera(8, 8, 10, 4, 4);
  const auto m = torch::zeros({2, 3}), c = torch::zeros({2, 6}), col = torch::zeros({2, 3}), o = torch::zeros({2});
  RasterSettings settings;
  CHECK(error_headline([&] { rasterize_gaussians(torch::zeros({2, 4}), c, col, o, cam, settings); }) ==
        "rasterize_gaussians: means must be [N, 3], got [2, 4]");
  CHECK(error_headline([&] { rasterize_gaussians(m, torch::zeros({2, 9}), col, o, cam, settings); }) ==
        "rasterize_gaussians: covariances must be [2, 6], got [2, 9]");
  CHECK(error_headline([&] { rasterize_gaussians(m, c, torch::zeros({3, 3}), o, cam, settings); }) ==
        "rasterize_gaussians: colors must be [2, 3], got [3, 3]");
  CHECK(error_headline([&] { rasterize_gaussians(m, c, col, torch::zeros({2, 2}), cam, settings); }) ==
        "rasterize_gaussians: opacities must be [2] or [2, 1], got [2, 2]");
  CHECK(error_headline([&] { rasterize_gaussians(m, c.to(torch::kFloat64), col, o, cam, settings); }) ==
        "rasterize_gaussians: covariances must have the dtype of means (Float), got Double");
  CHECK(error_headline([&] { rasterize_gaussians(m.to(torch::kInt32), c, col, o, cam, settings); }) ==
        "rasterize_gaussians: means must be float32 or float64, got Int");
  CHECK(error_headline([&] { rasterize_gaussians(m, c, col, o, cam, settings, torch::zeros({2, 3})); }) ==
        "rasterize_gaussians: means2d_probe must be [2, 2], got [2, 3]");
  Camera skew = cam;
  skew.K[1] = 0.5;
  CHECK(error_headline([&] { rasterize_gaussians(m, c, col, o, skew, settings); }) ==
        "rasterize_gaussians: camera K must be [[fx, 0, cx], [0, fy, cy], [0, 0, 1]], got [[10, 0.5, 4], [0, 10, 4], "
        "[0, 0, 1]]");
  Camera clip = cam;
  clip.far_plane = clip.near_plane;
  CHECK(error_headline([&] { rasterize_gaussians(m, c, col, o, clip, settings); }) ==
        "rasterize_gaussians: need 0 < near_plane < far_plane, got 0.01, 0.01");
  Camera empty = cam;
  empty.width = 0;
  CHECK(error_headline([&] { rasterize_gaussians(m, c, col, o, empty, settings); }) ==
        "rasterize_gaussians: camera size must be positive, got 0x8");
  RasterSettings roi;
  roi.roi = PixelRect{2, 2, 9, 5};
  CHECK(error_headline([&] { rasterize_gaussians(m, c, col, o, cam, roi); }) ==
        "rasterize_gaussians: roi [2, 9) x [2, 5) is not inside the 8x8 image");
  // Opacities [N, 1] are accepted and get [N, 1] gradients.
  auto o2 = torch::full({2, 1}, 0.5).requires_grad_(true);
  rasterize_gaussians(m, c, col, o2, cam, settings).rgb.sum().backward();
  CHECK(o2.grad().sizes() == c10::IntArrayRef({2, 1}));
}

TEST_CASE("means2d_probe receives dL/d(2D mean) and shifts the splat") {
  const Camera cam = plain_camera(16, 16, 100, 8.5, 8.5);  // the mean projects to the centre of pixel (8, 8)
  const auto means = t64({0, 0, 2}, {1, 3}), covs = t64({0.0025, 0, 0, 0.0025, 0, 0.0025}, {1, 6});
  const auto colors = t64({1, 1, 1}, {1, 3}), opac = t64({0.5}, {1});
  RasterSettings settings;
  auto probe = torch::zeros({1, 2}, torch::kFloat64).requires_grad_(true);
  auto m = means.clone().requires_grad_(true);
  const RasterOutput out = rasterize_gaussians(m, covs, colors, opac, cam, settings, probe);
  // Loss = alpha at pixel (10, 8): pulling the mean right (+u) increases it.
  out.alpha[8][10].backward();
  CHECK(probe.grad()[0][0].item<double>() > 0);
  CHECK(std::abs(probe.grad()[0][1].item<double>()) < 1e-3 * probe.grad()[0][0].item<double>() + 1e-9);
  // d/dx of the world mean = d/du * fx / z (R = I).
  CHECK(m.grad()[0][0].item<double>() == Approx(probe.grad()[0][0].item<double>() * 100 / 2).epsilon(1e-10));
  // A probe value of (+2, 0) px moves the splat by 2 px.
  const RasterOutput shifted = rasterize_gaussians(means, covs, colors, opac, cam, settings, t64({2, 0}, {1, 2}));
  CHECK(shifted.alpha[8][10].item<double>() == Approx(out.alpha[8][8].item<double>()).epsilon(1e-12));
}
