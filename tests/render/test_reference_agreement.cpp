// The kernel against the dense tensor-op reference: images, and vector-Jacobian products under a random cotangent.
#include "catch_torch.h"  // first: torch, minus glog's CHECK, then Catch2

#include "render/reference.h"
#include "render_test_util.h"

using namespace handscs;
using namespace handscs::test;

namespace {

struct Comparison {
  double image = 0, alpha = 0, depth = 0;                 // max abs differences
  double v_means = 0, v_covs = 0, v_colors = 0, v_opacities = 0, v_probe = 0;  // relative 2-norm errors
};

Comparison compare(const Scene& s, const RasterSettings& settings, uint64_t seed) {
  const int64_t n = s.means.size(0);
  auto run = [&](bool reference, std::vector<torch::Tensor>& grads) {
    auto means = s.means.clone().requires_grad_(true), covs = s.covs.clone().requires_grad_(true);
    auto colors = s.colors.clone().requires_grad_(true), opac = s.opacities.clone().requires_grad_(true);
    auto probe = torch::zeros({n, 2}, s.means.options()).requires_grad_(true);
    const RasterOutput out =
        reference ? rasterize_gaussians_reference(means, covs, colors, opac, s.camera, settings, probe)
                  : rasterize_gaussians(means, covs, colors, opac, s.camera, settings, probe);
    const auto w = random_weights(out.rgb.size(0), out.rgb.size(1), seed, s.means.scalar_type());
    loss_of(out, w).backward();
    grads = {means.grad(), covs.grad(), colors.grad(), opac.grad(), probe.grad()};
    return out;
  };
  std::vector<torch::Tensor> gk, gr;
  const RasterOutput k = run(false, gk), r = run(true, gr);
  Comparison c;
  c.image = max_abs(k.rgb, r.rgb);
  c.alpha = max_abs(k.alpha, r.alpha);
  c.depth = settings.compute_depth ? max_abs(k.depth, r.depth) : 0.0;
  c.v_means = rel_err(gk[0], gr[0]);
  c.v_covs = rel_err(gk[1], gr[1]);
  c.v_colors = rel_err(gk[2], gr[2]);
  c.v_opacities = rel_err(gk[3], gr[3]);
  c.v_probe = rel_err(gk[4], gr[4]);
  return c;
}

void check_agreement(torch::Dtype dtype, double image_tol, double grad_tol) {
  Comparison worst;
  for (int seed = 0; seed < 12; ++seed) {
    SceneOptions o;
    o.dtype = dtype;
    o.width = 64;
    o.height = 48;
    o.num_gaussians = 80;
    o.focal = 60;
    Scene s = random_scene(o, 1000 + seed);
    RasterSettings settings;
    settings.background = {0.2f, 0.5f, 0.9f};
    settings.compute_depth = seed % 2 == 1;
    if (seed % 3 == 2) settings.roi = PixelRect{5, 7, 50, 40};
    const Comparison c = compare(s, settings, 77 + seed);
    worst.image = std::max(worst.image, std::max(c.image, c.alpha));
    worst.depth = std::max(worst.depth, c.depth);
    worst.v_means = std::max(worst.v_means, c.v_means);
    worst.v_covs = std::max(worst.v_covs, c.v_covs);
    worst.v_colors = std::max(worst.v_colors, c.v_colors);
    worst.v_opacities = std::max(worst.v_opacities, c.v_opacities);
    worst.v_probe = std::max(worst.v_probe, c.v_probe);
  }
  INFO("image " << worst.image << " depth " << worst.depth << " v_means " << worst.v_means << " v_covs "
                << worst.v_covs << " v_colors " << worst.v_colors << " v_opacities " << worst.v_opacities
                << " v_probe " << worst.v_probe);
  WARN("agreement (" << (dtype == torch::kFloat32 ? "float" : "double") << "): image " << worst.image << " depth "
                     << worst.depth << " v_means " << worst.v_means << " v_covs " << worst.v_covs << " v_colors "
                     << worst.v_colors << " v_opacities " << worst.v_opacities << " v_probe " << worst.v_probe);
  CHECK(worst.image <= image_tol);
  CHECK(worst.depth <= image_tol * 100);
  CHECK(worst.v_means <= grad_tol);
  CHECK(worst.v_covs <= grad_tol);
  CHECK(worst.v_colors <= grad_tol);
  CHECK(worst.v_opacities <= grad_tol);
  CHECK(worst.v_probe <= grad_tol);
}

}  // namespace

TEST_CASE("kernel agrees with the reference in float (image 1e-5, VJP 1e-4)") {
  const SingleThreadScope single_thread;
  check_agreement(torch::kFloat32, 1e-5, 1e-4);
}

TEST_CASE("kernel agrees with the reference in double") {
  const SingleThreadScope single_thread;
  check_agreement(torch::kFloat64, 1e-12, 1e-9);
}
