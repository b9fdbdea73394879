// Colours from features (infer/feature_pca.h): standardisation, principal axes of data whose axes
// and variances are known by construction, numpy-style percentiles, and one colouring for all poses.
#include "catch_torch.h"

#include "infer/feature_pca.h"

namespace {
// An orthogonal matrix with rational entries (columns q1, q2, q3; Q^T Q = I checked below).
torch::Tensor orthogonal() {
  return torch::tensor({2.0, -1.0, 2.0, 2.0, 2.0, -1.0, -1.0, 2.0, 2.0}, torch::kFloat64).view({3, 3}) / 3;
}
}  // namespace

TEST_CASE("feature pca: standardisation uses the population std and leaves constant columns unscaled") {
  const auto x = torch::tensor({1.0, 5.0, 2.0, 5.0, 3.0, 5.0, 4.0, 5.0}, torch::kFloat64).view({4, 2});
  const auto s = handscs::fit_standardizer(x);
  CHECK(s.mean[0].item<double>() == 2.5);
  CHECK(s.scale[0].item<double>() == Approx(std::sqrt(1.25)).epsilon(1e-15));
  CHECK(s.scale[1].item<double>() == 1.0);
  const auto z = s.apply(x);
  CHECK(z[0][0].item<double>() == Approx(-1.5 / std::sqrt(1.25)).epsilon(1e-15));
  CHECK(z.select(1, 1).abs().max().item<double>() == 0.0);
}

TEST_CASE("feature pca: the axes and variance shares of points on three known orthogonal axes") {
  const auto q = orthogonal();
  REQUIRE(torch::allclose(q.t().matmul(q), torch::eye(3, torch::kFloat64), 0, 1e-15));
  // +-3 q1, +-2 q2, +-1 q3 (and a shift): covariance Q diag(18, 8, 2) Q^T / 5.
  const auto coords = torch::tensor({3.0, 0.0, 0.0, -3.0, 0.0, 0.0, 0.0, 2.0, 0.0, 0.0, -2.0, 0.0, 0.0, 0.0, 1.0,
                                     0.0, 0.0, -1.0}, torch::kFloat64).view({6, 3});
  const auto shift = torch::tensor({0.3, -7.0, 2.0}, torch::kFloat64);
  const auto x = coords.matmul(q.t()) + shift;
  const auto pca = handscs::fit_pca(x, 3);
  // Each q_k has its largest-magnitude loading positive, so the signs are q's own.
  CHECK(torch::allclose(pca.components, q.t(), 0, 1e-12));
  CHECK(pca.explained[0].item<double>() == Approx(18.0 / 28).epsilon(1e-12));
  CHECK(pca.explained[1].item<double>() == Approx(8.0 / 28).epsilon(1e-12));
  CHECK(pca.explained[2].item<double>() == Approx(2.0 / 28).epsilon(1e-12));
  CHECK(torch::allclose(pca.project(x), coords, 0, 1e-12));
  // Asking for more axes than columns gives the columns' count.
  CHECK(handscs::fit_pca(x.slice(1, 0, 2), 3).components.size(0) == 2);
}

TEST_CASE("feature pca: colour ranges are numpy's linear percentiles, fitted once for every pose") {
  const auto ramp = torch::arange(0, 101, torch::kFloat64).unsqueeze(1);
  auto range = handscs::fit_colour_range(ramp, 1.0);
  CHECK(range.lo.item<double>() == Approx(1.0).epsilon(1e-15));
  CHECK(range.hi.item<double>() == Approx(99.0).epsilon(1e-15));
  CHECK(range.apply(torch::tensor({{50.0}, {0.0}, {100.0}}, torch::kFloat64)).flatten()[0].item<double>() ==
        Approx(49.0 / 98).epsilon(1e-15));
  // np.percentile(range(10), [10, 90]) = [0.9, 8.1].
  range = handscs::fit_colour_range(torch::arange(0, 10, torch::kFloat64).unsqueeze(1), 10.0);
  CHECK(range.lo.item<double>() == Approx(0.9).epsilon(1e-12));
  CHECK(range.hi.item<double>() == Approx(8.1).epsilon(1e-12));
  const auto clamped = range.apply(torch::tensor({{0.0}, {9.0}}, torch::kFloat64));
  CHECK(clamped[0][0].item<double>() == 0.0);
  CHECK(clamped[1][0].item<double>() == 1.0);

  // One colouring of two "poses" pooled: each pose's colours are its rows of the pooled colours,
  // whatever the other pose holds (the basis is not refitted per pose).
  torch::manual_seed(1);
  const auto pose_a = torch::randn({40, 6}, torch::kFloat64);
  const auto pose_b = torch::randn({40, 6}, torch::kFloat64) * 3 + 1;
  const auto colouring = handscs::fit_feature_colouring(torch::cat({pose_a, pose_b}), 1.0);
  const auto pooled = colouring.colours(torch::cat({pose_a, pose_b}));
  CHECK(pooled.sizes() == torch::IntArrayRef({80, 3}));
  CHECK(pooled.min().item<double>() >= 0.0);
  CHECK(pooled.max().item<double>() <= 1.0);
  CHECK(torch::equal(colouring.colours(pose_a), pooled.slice(0, 0, 40)));
  CHECK(torch::equal(colouring.colours(pose_b), pooled.slice(0, 40, 80)));
}
