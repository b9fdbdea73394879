// Gradients against central finite differences in double precision, for the kernel and for the reference, on
// tiny scenes built away from the non-smooth points (every alpha in (1/255, 0.99), T stays above 1e-4, colours in
// (0, 1)); the fixture asserts that it is. One Gaussian sits outside 1.3x the field of view so the clamped EWA
// Jacobian's gradient path is checked too. Fourth-order central differences (error O(h^4), so the steps can be
// large enough to keep rounding small): means 1e-4 m, covariances 1e-5 m^2, colours and opacities 1e-4, probe
// 1e-3 px; tolerance 1e-6 relative (to 1e-3 + |gradient|). Perturbing covariance entry xy moves Sigma_xy and
// Sigma_yx together, so agreement here proves the convention documented in rasterize.h: an off-diagonal slot
// receives dL/dSigma_xy + dL/dSigma_yx.
#include "catch_torch.h"  // first: torch, minus glog's CHECK, then Catch2

#include <functional>

#include "render/reference.h"
#include "render_test_util.h"

using namespace handscs;
using namespace handscs::test;

namespace {

struct Inputs {
  torch::Tensor means, covs, colors, opacities, probe;
};

// 16x16 image, focal 16 px: 5 Gaussians with projected sigma 7-9 px inside the image, and one centred at
// x/z = -1.44 (clamp limit -0.65) whose 13 px sigma still covers the image.
Inputs smooth_scene(uint64_t seed, Camera& cam) {
  SceneOptions o;
  o.num_gaussians = 5;
  o.width = o.height = 16;
  o.focal = 16;
  o.sigma_px_lo = 7;
  o.sigma_px_hi = 9;
  o.opacity_lo = 0.3;
  o.opacity_hi = 0.6;
  o.color_lo = 0.1;
  o.color_hi = 0.9;
  o.depth_lo = 0.8;
  o.depth_hi = 1.2;
  o.margin_px = -4;  // centres in [4, 12]
  const Scene s = random_scene(o, seed);
  cam = s.camera;
  Inputs in;
  const auto w = from_camera(cam, {-1.44, 0.1, 1.0});
  const auto extra_mean = torch::tensor(std::vector<double>{w[0], w[1], w[2]}, torch::kFloat64).view({1, 3});
  const double sz = 13.0 / 16.0;
  const auto extra_cov =
      covariance_from_scale_rotation(torch::full({1, 3}, sz, torch::kFloat64),
                                     torch::tensor(std::vector<double>{0.9, 0.2, 0.1, -0.3}, torch::kFloat64).view({1, 4}));
  in.means = torch::cat({s.means, extra_mean});
  in.covs = torch::cat({s.covs, extra_cov});
  in.colors = torch::cat({s.colors, torch::tensor(std::vector<double>{0.7, 0.2, 0.4}, torch::kFloat64).view({1, 3})});
  in.opacities = torch::cat({s.opacities, torch::tensor(std::vector<double>{0.5}, torch::kFloat64)});
  in.probe = torch::zeros({6, 2}, torch::kFloat64);
  return in;
}

using Renderer = std::function<RasterOutput(const Inputs&, const Camera&, const RasterSettings&)>;

struct FdReport {
  double max_rel = 0;  // max |fd - analytic| / (1e-3 + |analytic|) over every input entry
  int64_t checked = 0;
};

FdReport check_fd(const Renderer& render, const Inputs& base, const Camera& cam, const RasterSettings& settings,
                  uint64_t seed) {
  const auto w = random_weights(16, 16, seed, torch::kFloat64);
  Inputs in{base.means.clone().requires_grad_(true), base.covs.clone().requires_grad_(true),
            base.colors.clone().requires_grad_(true), base.opacities.clone().requires_grad_(true),
            base.probe.clone().requires_grad_(true)};
  loss_of(render(in, cam, settings), w).backward();
  const std::vector<std::pair<torch::Tensor*, double>> params = {
      {&in.means, 1e-4}, {&in.covs, 1e-5}, {&in.colors, 1e-4}, {&in.opacities, 1e-4}, {&in.probe, 1e-3}};
  FdReport report;
  torch::NoGradGuard no_grad;
  for (const auto& [param, h] : params) {
    const auto grad = param->grad().clone();
    auto flat = param->view({-1});
    for (int64_t k = 0; k < flat.numel(); ++k) {
      const double x0 = flat[k].item<double>();
      auto loss_at = [&](double x) {
        flat[k] = x;
        return loss_of(render(in, cam, settings), w).item<double>();
      };
      // Fourth-order central difference: error O(h^4) instead of O(h^2).
      const double fd = (8 * (loss_at(x0 + h) - loss_at(x0 - h)) - (loss_at(x0 + 2 * h) - loss_at(x0 - 2 * h))) / (12 * h);
      flat[k] = x0;
      const double an = grad.view({-1})[k].item<double>();
      report.max_rel = std::max(report.max_rel, std::abs(fd - an) / (1e-3 + std::abs(an)));
      ++report.checked;
    }
  }
  return report;
}

// The fixture stays clear of every threshold: all alphas in (1.5/255, 0.95) and T_final > 1e-3.
void check_fixture_is_smooth(const Inputs& in, const Camera& cam) {
  RasterSettings settings;
  const RasterOutput out = rasterize_gaussians(in.means, in.covs, in.colors, in.opacities, cam, settings);
  REQUIRE((out.radii > 0).all().item<bool>());
  REQUIRE(out.alpha.max().item<double>() < 1 - 1e-3);
  for (int64_t i = 0; i < in.means.size(0); ++i) {
    const auto one = [&](const torch::Tensor& t) { return t.narrow(0, i, 1); };
    const RasterOutput single =
        rasterize_gaussians(one(in.means), one(in.covs), one(in.colors), one(in.opacities), cam, settings);
    REQUIRE(single.alpha.min().item<double>() > 1.5 / 255);
    REQUIRE(single.alpha.max().item<double>() < 0.95);
  }
}

RasterOutput run_kernel(const Inputs& in, const Camera& cam, const RasterSettings& s) {
  return rasterize_gaussians(in.means, in.covs, in.colors, in.opacities, cam, s, in.probe);
}

RasterOutput run_reference(const Inputs& in, const Camera& cam, const RasterSettings& s) {
  return rasterize_gaussians_reference(in.means, in.covs, in.colors, in.opacities, cam, s, in.probe);
}

}  // namespace

TEST_CASE("reference rasterizer matches finite differences (double)") {
  const SingleThreadScope single_thread;
  for (uint64_t seed : {11, 12}) {
    Camera cam;
    const Inputs in = smooth_scene(seed, cam);
    check_fixture_is_smooth(in, cam);
    RasterSettings settings;
    settings.background = {0.3f, 0.6f, 0.1f};
    settings.compute_depth = true;
    const FdReport r = check_fd(run_reference, in, cam, settings, seed);
    WARN("reference vs finite differences: max relative error " << r.max_rel << " over " << r.checked
                                                                << " entries");
    CHECK(r.checked == 6 * (3 + 6 + 3 + 1 + 2));
    CHECK(r.max_rel < 1e-6);
  }
}

TEST_CASE("kernel gradients match finite differences (double), incl. the 6-entry covariance convention") {
  const SingleThreadScope single_thread;
  for (uint64_t seed : {11, 12, 13}) {
    Camera cam;
    const Inputs in = smooth_scene(seed, cam);
    check_fixture_is_smooth(in, cam);
    RasterSettings settings;
    settings.background = {0.3f, 0.6f, 0.1f};
    settings.compute_depth = seed != 12;
    const FdReport r = check_fd(run_kernel, in, cam, settings, seed);
    WARN("kernel vs finite differences: max relative error " << r.max_rel << " over " << r.checked << " entries");
    CHECK(r.max_rel < 1e-6);
  }
}
