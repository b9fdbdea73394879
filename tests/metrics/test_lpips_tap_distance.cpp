// lpips_tap_distance (one LPIPS tap's map at evaluation) against LibTorch's form
// (unit_normalize_channels, square, 1x1 conv): random features of AlexNet's and VGG's channel
// counts in float and double, all-zero feature vectors, features so small that eps matters, NaN
// and inf; Lpips::layer_distances keeps LibTorch's form when a gradient is wanted.
#include "metrics_test_utils.h"  // first: brings Catch2 in after torch (see there)

#include <cmath>
#include <limits>

#include "metrics/lpips.h"
#include "metrics/lpips_tap_distance.h"

namespace {

// Lpips::layer_distances' form with a graph: the independent reference.
torch::Tensor tap_distance_libtorch(const torch::Tensor& fx,    // [B, C, H, W]
                                    const torch::Tensor& fy,    // [B, C, H, W]
                                    const torch::Tensor& lin) {  // [C]
  const auto diff = (handscs::unit_normalize_channels(fx) - handscs::unit_normalize_channels(fy)).square();
  return at::conv2d(diff, lin.view({1, -1, 1, 1}));
}

// max over pixels of |a - b| / |b| (in double; 0 where both are 0, NaN where either is NaN).
double tap_relative_difference(const torch::Tensor& a, const torch::Tensor& b) {
  const auto a64 = a.to(torch::kDouble), b64 = b.to(torch::kDouble);
  return ((a64 - b64).abs() / b64.abs().clamp_min(std::numeric_limits<double>::min())).max().item<double>();
}

// Tolerances relative to the value: the channel sums run in another order than LibTorch's
// reduction and the conv's GEMM (up to 384 terms of rounding in the features' dtype).
double tap_tolerance(torch::Dtype dtype) { return dtype == torch::kDouble ? 1e-12 : 1e-5; }

// LPIPS lin weights are non-negative; these are [0, 1).
torch::Tensor tap_lin(int64_t channels, torch::Dtype dtype) { return torch::rand({channels}, dtype); }

}  // namespace

TEST_CASE("lpips_tap_distance equals LibTorch's form on random features", "[lpips][tap_distance]") {
  torch::manual_seed(91);
  const std::vector<std::vector<int64_t>> sizes = {{1, 1, 1}, {2, 7, 37}, {1, 21, 25}, {2, 3, 95}};
  for (const auto dtype : {torch::kFloat32, torch::kFloat64})
    for (const int64_t channels : {64, 192, 384})
      for (const auto& s : sizes)
        for (const bool relu : {false, true}) {  // signed values, and backbone-like ReLU outputs
          INFO("dtype " << dtype << ", B " << s[0] << ", C " << channels << ", " << s[1] << "x" << s[2]
                        << (relu ? ", relu" : ""));
          auto fx = torch::randn({s[0], channels, s[1], s[2]}, dtype);
          auto fy = torch::randn({s[0], channels, s[1], s[2]}, dtype);
          if (relu) {
            fx = fx.relu();
            fy = fy.relu();
          }
          const auto lin = tap_lin(channels, dtype);
          const auto ours = handscs::lpips_tap_distance(fx, fy, lin);
          REQUIRE(ours.sizes() == at::IntArrayRef({s[0], 1, s[1], s[2]}));
          CHECK(ours.scalar_type() == dtype);
          const double difference = tap_relative_difference(ours, tap_distance_libtorch(fx, fy, lin));
          INFO("max relative difference " << difference);
          CHECK(difference <= tap_tolerance(dtype));
        }
  // Non-contiguous features are read as their values.
  const auto fx = torch::randn({1, 64, 9, 11}, torch::kDouble), fy = torch::randn({1, 64, 9, 11}, torch::kDouble);
  const auto lin = tap_lin(64, torch::kDouble);
  CHECK(tap_relative_difference(handscs::lpips_tap_distance(fx.transpose(2, 3), fy.transpose(2, 3), lin),
                                tap_distance_libtorch(fx.transpose(2, 3), fy.transpose(2, 3), lin)) <= 1e-12);
}

TEST_CASE("lpips_tap_distance takes the norm's zero branch as LibTorch's form does",
          "[lpips][tap_distance]") {
  torch::manual_seed(92);
  for (const auto dtype : {torch::kFloat32, torch::kFloat64}) {
    INFO("dtype " << dtype);
    auto fx = torch::randn({2, 64, 3, 5}, dtype);
    auto fy = torch::randn({2, 64, 3, 5}, dtype);
    using torch::indexing::Slice;
    fx.index({1, Slice(), 0, 0}).zero_();  // x zero at (1, 0, 0)
    fy.index({1, Slice(), 0, 1}).zero_();  // y zero at (1, 0, 1)
    fx.index({0, Slice(), 2, 4}).zero_();  // both zero at (0, 2, 4)
    fy.index({0, Slice(), 2, 4}).zero_();
    const auto lin = tap_lin(64, dtype);
    const auto ours = handscs::lpips_tap_distance(fx, fy, lin);
    const auto reference = tap_distance_libtorch(fx, fy, lin);
    REQUIRE(reference.isfinite().all().item<bool>());  // eps keeps 0 / 0 away
    CHECK(tap_relative_difference(ours, reference) <= tap_tolerance(dtype));
    CHECK(ours[0][0][2][4].item<double>() == 0.0);
    // One side zero: n = 0 there, so the map is sum_c w_c n(f_other)_c^2 of the other side alone.
    const auto ny = fy.index({1, Slice(), 0, 0});  // [C]
    const double alone = (lin * (ny / (ny.square().sum().sqrt() + 1e-10)).square()).sum().item<double>();
    CHECK_THAT(ours[1][0][0][0].item<double>(), Catch::Matchers::WithinRel(alone, tap_tolerance(dtype)));
  }
}

TEST_CASE("lpips_tap_distance keeps eps where features are as small as it", "[lpips][tap_distance]") {
  torch::manual_seed(93);
  // |f| of 64 channels at scale s is ~8 s: at 1e-12 eps (1e-10) dominates the denominator, at 1e-10
  // it is ~11% of it. Float holds these squares (~1e-24) as normal numbers.
  for (const auto dtype : {torch::kFloat32, torch::kFloat64})
    for (const double scale : {1e-12, 1e-10}) {
      INFO("dtype " << dtype << ", scale " << scale);
      const auto fx = torch::randn({1, 64, 5, 7}, dtype) * scale;
      const auto fy = torch::randn({1, 64, 5, 7}, dtype) * scale;
      const auto lin = tap_lin(64, dtype);
      const auto reference = tap_distance_libtorch(fx, fy, lin);
      CHECK(tap_relative_difference(handscs::lpips_tap_distance(fx, fy, lin), reference) <= tap_tolerance(dtype));
      // The check above can fail: kernels that forget eps, put it under the root, or take another
      // norm are this far from the reference on these features.
      const auto mutant = [&](const std::function<torch::Tensor(const torch::Tensor&)>& normalize) {
        return at::conv2d((normalize(fx) - normalize(fy)).square(), lin.view({1, -1, 1, 1}));
      };
      const auto sum_sq = [](const torch::Tensor& f) { return f.square().sum(1, true); };
      const auto no_eps = mutant([&](const torch::Tensor& f) { return f / sum_sq(f).sqrt(); });
      const auto eps_in_root = mutant([&](const torch::Tensor& f) { return f / (sum_sq(f) + 1e-10).sqrt(); });
      const auto l1_norm = mutant([&](const torch::Tensor& f) { return f / (f.abs().sum(1, true) + 1e-10); });
      const double margin = 100 * tap_tolerance(dtype);
      CHECK(tap_relative_difference(no_eps, reference) > margin);
      CHECK(tap_relative_difference(eps_in_root, reference) > margin);
      CHECK(tap_relative_difference(l1_norm, reference) > margin);
    }
}

TEST_CASE("lpips_tap_distance gives NaN where a feature is NaN or infinite, as LibTorch's form",
          "[lpips][tap_distance]") {
  torch::manual_seed(94);
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  for (const auto dtype : {torch::kFloat32, torch::kFloat64})
    for (const double bad : {nan, inf}) {
      INFO("dtype " << dtype << ", bad value " << bad);
      auto fx = torch::randn({2, 64, 4, 6}, dtype);
      auto fy = torch::randn({2, 64, 4, 6}, dtype);
      fx[1][5][2][3] = bad;   // x at (1, 2, 3)
      fy[0][63][0][0] = bad;  // y at (0, 0, 0)
      const auto lin = tap_lin(64, dtype);
      const auto ours = handscs::lpips_tap_distance(fx, fy, lin);
      const auto reference = tap_distance_libtorch(fx, fy, lin);
      CHECK(torch::equal(ours.isnan(), reference.isnan()));
      CHECK(ours.isnan().sum().item<int64_t>() == 2);
      CHECK(std::isnan(ours[1][0][2][3].item<double>()));
      CHECK(std::isnan(ours[0][0][0][0].item<double>()));
      const auto finite = reference.isfinite();
      CHECK(tap_relative_difference(ours.masked_select(finite), reference.masked_select(finite)) <=
            tap_tolerance(dtype));
      // The spatial mean passes the NaN on: no score averages it away.
      const auto means = handscs::lpips_from_layers({ours});
      CHECK(means.isnan().all().item<bool>());
    }
}

TEST_CASE("Lpips::layer_distances takes the fused map at evaluation and LibTorch's form for gradients",
          "[lpips][tap_distance]") {
  const auto lpips = metrics_test::load_alex();
  const auto x = metrics_test::smooth_image({1, 3, 64, 72}, 95, torch::kFloat);
  const auto y = metrics_test::smooth_image({1, 3, 64, 72}, 96, torch::kFloat);
  const auto evaluation = lpips.layer_distances(x, y);
  const auto taps_x = lpips.features(x), taps_y = lpips.features(y);
  const auto x_grad = x.clone().set_requires_grad(true);
  const auto with_graph = lpips.layer_distances(x_grad, y);
  REQUIRE(evaluation.size() == with_graph.size());
  for (size_t t = 0; t < evaluation.size(); ++t) {
    INFO("tap " << t);
    CHECK_FALSE(evaluation[t].requires_grad());
    CHECK(with_graph[t].requires_grad());
    CHECK(tap_relative_difference(evaluation[t], with_graph[t].detach()) <= 1e-5);
    const auto lin = torch::ones({taps_x[t].size(1)});  // weights of 1: the plain squared distance
    CHECK(tap_relative_difference(handscs::lpips_tap_distance(taps_x[t], taps_y[t], lin),
                                  tap_distance_libtorch(taps_x[t], taps_y[t], lin)) <= 1e-5);
  }
}

TEST_CASE("lpips_tap_distance names what is wrong with its input", "[lpips][tap_distance]") {
  const auto f = torch::zeros({1, 4, 2, 3});
  CHECK_THROWS_WITH(handscs::lpips_tap_distance(f, torch::zeros({1, 4, 2, 2}), torch::zeros({4})),
                    Catch::Contains("feature sizes differ: [1, 4, 2, 3] vs [1, 4, 2, 2]"));
  CHECK_THROWS_WITH(handscs::lpips_tap_distance(f, f, torch::zeros({1, 4, 1, 1})),
                    Catch::Contains("lin must be [4], got [1, 4, 1, 1]"));
  CHECK_THROWS_WITH(handscs::lpips_tap_distance(f, f.to(torch::kDouble), torch::zeros({4})),
                    Catch::Contains("dtypes differ: Float, Double, lin Float"));
  CHECK_THROWS_WITH(handscs::lpips_tap_distance(f.to(torch::kInt32), f.to(torch::kInt32), torch::zeros({4})),
                    Catch::Contains("float or double, got Int"));
  CHECK_THROWS_WITH(handscs::lpips_tap_distance(f[0], f[0], torch::zeros({4})),
                    Catch::Contains("features must be [B, C, H, W], got [4, 2, 3]"));
}
