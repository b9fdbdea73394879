// max_pool_2d (LPIPS's pooling at evaluation) against at::max_pool2d: equal values for both
// backbones' windows, odd sizes, both dtypes; NaN propagates as LibTorch's does; the switch keeps
// autograd's pooling when a gradient is wanted.
#include "catch_torch.h"

#include <limits>

#include <torch/types.h>

#include "metrics/max_pool.h"

namespace {

// Equal values, a NaN where the other has one.
bool same_values(const torch::Tensor& a, const torch::Tensor& b) {
  return a.sizes() == b.sizes() && torch::equal(a.isnan(), b.isnan()) &&
         torch::equal(torch::nan_to_num(a, 0.0), torch::nan_to_num(b, 0.0));
}

}  // namespace

TEST_CASE("max_pool_2d equals at::max_pool2d (AlexNet's 3/2 and VGG's 2/2 windows)", "[max_pool]") {
  torch::manual_seed(8);
  for (const auto dtype : {torch::kFloat32, torch::kFloat64})
    for (const auto& window : {std::pair<int64_t, int64_t>{3, 2}, {2, 2}, {3, 1}})
      for (const auto& size : {std::vector<int64_t>{2, 64, 127, 83}, std::vector<int64_t>{1, 3, 7, 10}}) {
        INFO("dtype " << dtype << ", kernel " << window.first << ", stride " << window.second << ", "
                      << size[2] << "x" << size[3]);
        auto x = torch::randn(size, dtype);
        x.view(-1).slice(0, 0, 40).fill_(-std::numeric_limits<double>::infinity());  // -inf windows
        const auto ours = handscs::max_pool_2d(x, window.first, window.second);
        const auto theirs = at::max_pool2d(x, {window.first, window.first}, {window.second, window.second});
        CHECK(same_values(ours, theirs));
      }
}

TEST_CASE("max_pool_2d propagates NaN as at::max_pool2d does", "[max_pool]") {
  auto x = torch::randn({1, 2, 9, 9});
  x[0][0][4][4] = std::numeric_limits<float>::quiet_NaN();
  x[0][1][0][0] = std::numeric_limits<float>::quiet_NaN();
  const auto ours = handscs::max_pool_2d(x, 3, 2);
  const auto theirs = at::max_pool2d(x, {3, 3}, {2, 2});
  CHECK(ours.isnan().sum().item<int64_t>() == theirs.isnan().sum().item<int64_t>());
  CHECK(ours.isnan().sum().item<int64_t>() > 0);
  CHECK(same_values(ours, theirs));
}

TEST_CASE("max_pool_2d_any keeps autograd's pooling when a gradient is wanted", "[max_pool]") {
  const auto x = torch::randn({1, 2, 9, 9}).requires_grad_(true);
  const auto y = handscs::max_pool_2d_any(x, 3, 2);
  REQUIRE(y.requires_grad());
  y.sum().backward();
  // Each output's gradient lands on its window's maximum: one 1 per output (distinct values).
  CHECK(x.grad().sum().item<double>() == Approx(static_cast<double>(y.numel())));
  torch::NoGradGuard no_grad;
  CHECK_FALSE(handscs::max_pool_2d_any(x, 3, 2).requires_grad());
  CHECK(torch::equal(handscs::max_pool_2d_any(x, 3, 2), y.detach()));
}

TEST_CASE("max_pool_2d names what is wrong with its input", "[max_pool]") {
  CHECK_THROWS_WITH(handscs::max_pool_2d(torch::zeros({1, 2, 2, 9}), 3, 2),
                    Catch::Contains("2x9 is smaller than the 3x3 window"));
  CHECK_THROWS_WITH(handscs::max_pool_2d(torch::zeros({2, 9, 9}), 3, 2), Catch::Contains("expected [B, C, H, W]"));
  CHECK_THROWS_WITH(handscs::max_pool_2d(torch::zeros({1, 1, 9, 9}, torch::kInt32), 3, 2),
                    Catch::Contains("float or double"));
}
