// projected_radii (render/projected_radii.h) against the rasterizer's own radii, with Gaussians
// behind the camera, outside the image, below the opacity threshold and non-finite.
#include "catch_torch.h"

#include <cmath>

#include <torch/types.h>

#include "render/projected_radii.h"
#include "render/rasterize.h"

TEST_CASE("projected radii: equal to the rasterizer's radii") {
  auto gen = at::detail::createCPUGenerator(5);
  handscs::Camera camera;
  camera.width = 90;
  camera.height = 70;
  camera.K = {100, 0, 45, 0, 100, 35, 0, 0, 1};
  camera.t = {0, 0, 1};
  const int64_t n = 3000;
  for (const auto dtype : {torch::kFloat32, torch::kFloat64}) {
    auto means = (at::normal(0.0, 0.6, {n, 3}, gen, torch::kFloat64)).to(dtype);
    const auto axes = at::normal(0.0, 0.05, {n, 3, 3}, gen, torch::kFloat64);
    const auto sigma = axes.matmul(axes.transpose(1, 2));
    auto covs = torch::stack({sigma.select(1, 0).select(1, 0), sigma.select(1, 0).select(1, 1),
                              sigma.select(1, 0).select(1, 2), sigma.select(1, 1).select(1, 1),
                              sigma.select(1, 1).select(1, 2), sigma.select(1, 2).select(1, 2)}, 1)
                    .to(dtype);
    auto opacities = at::rand({n}, gen, torch::kFloat64).to(dtype);
    opacities.slice(0, 0, 100).mul_(1.0 / 128);  // many below 1/255
    means[3][0] = std::nan("");
    covs[4][0] = INFINITY;
    handscs::RasterSettings settings;
    const auto expected = handscs::rasterize_gaussians(means, covs, torch::zeros({n, 3}, dtype),
                                                       opacities, camera, settings).radii;
    const auto radii = handscs::projected_radii(means, covs, opacities, camera, settings);
    INFO((dtype == torch::kFloat32 ? "float" : "double"));
    CHECK(torch::equal(radii, expected));
    const int64_t seen = (radii > 0).sum().item<int64_t>();
    CHECK(seen > n / 10);
    CHECK(seen < n);  // some behind the camera, outside the image or too transparent
  }
}
