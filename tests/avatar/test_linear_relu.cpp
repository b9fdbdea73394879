// avatar/linear_relu.h: the bias + ReLU pass and the one-op hidden layer against the same formula in
// LibTorch ops (mm, float add, relu, cast to bf16, differentiated by LibTorch): bit for bit, except
// the bias gradient (a float sum in another order; bit for bit between the SIMD levels), with NaN
// in the values and in the gradient, widths that are not a multiple of the vector length, both
// SIMD levels, and one or two threads.
#include "catch_torch.h"

#include <torch/csrc/autograd/autograd.h>
#include <torch/types.h>

#include "avatar/linear_relu.h"
#include "core/simd_level.h"
#include "core/threads.h"
#include "tensor_bits.h"

namespace {

// bf16 values of either sign, some exactly 0 and some NaN.
torch::Tensor random_bf16(int64_t n, int64_t m, bool with_nan) {
  auto t = torch::randn({n, m}) * 3;
  t.view(-1).slice(0, 0, t.numel(), 17).zero_();
  if (with_nan) t.view(-1).slice(0, 5, t.numel(), 101).fill_(std::nan(""));
  return t.to(torch::kBFloat16);
}

// A SIMD level for one test section, then the detected one again. Warns when the AVX-512 kernels
// (AVX-512F and BW) cannot run here, so that section checks the generic code a second time.
struct LevelScope {
  explicit LevelScope(handscs::SimdLevel level) {
    const auto active = handscs::set_simd_level(level);
    if (level == handscs::SimdLevel::avx512 &&
        !(active == handscs::SimdLevel::avx512 && __builtin_cpu_supports("avx512bw")))
      WARN("no AVX-512BW here: the AVX-512 kernels are not checked");
  }
  ~LevelScope() { handscs::set_simd_level(handscs::detected_simd_level()); }
};

}  // namespace

TEST_CASE("add_bias_relu_: equals relu(float(y) + bias) cast to bf16, bit for bit") {
  torch::manual_seed(11);
  for (const int64_t m : {256, 37}) {  // 37: a tail of 5 past two 16-wide vectors
    for (const auto level : {handscs::SimdLevel::generic, handscs::SimdLevel::avx512}) {
      LevelScope scope(level);
      INFO("M = " << m << ", level " << handscs::simd_level_name(handscs::active_simd_level()));
      const auto y = random_bf16(300, m, /*with_nan=*/true);
      const auto column_bias = torch::randn({m});
      auto got = y.clone();
      handscs::add_bias_relu_(got, column_bias);
      CHECK(handscs_test::same_bits(got, torch::relu(y.to(torch::kFloat) + column_bias).to(torch::kBFloat16)));
      const auto nan = torch::isnan(got);
      CHECK(nan.sum().item<int64_t>() > 0);  // NaN kept, as LibTorch's relu
      CHECK((got.view(torch::kInt16).masked_select(nan) == 0x7FC0).all().item<bool>());  // c10's NaN

      const auto entry_bias = random_bf16(300, m, /*with_nan=*/false);
      got = y.clone();
      handscs::add_bias_relu_(got, entry_bias);
      CHECK(handscs_test::same_bits(got, torch::relu(y.to(torch::kFloat) + entry_bias.to(torch::kFloat)).to(torch::kBFloat16)));
    }
  }
}

TEST_CASE("add_bias_relu_: names what is wrong with its arguments") {
  auto y = torch::zeros({4, 8}, torch::kBFloat16);
  auto y_float = torch::zeros({4, 8});
  CHECK_THROWS_WITH(handscs::add_bias_relu_(y_float, torch::zeros({8})),
                    Catch::Contains("y must be a contiguous CPU bf16"));
  CHECK_THROWS_WITH(handscs::add_bias_relu_(y, torch::zeros({7})),
                    Catch::Contains("per-column bias must be contiguous float [8]"));
  CHECK_THROWS_WITH(handscs::add_bias_relu_(y, torch::zeros({4, 8})),
                    Catch::Contains("per-entry bias must be contiguous bf16"));
  CHECK_THROWS_WITH(handscs::linear_relu(torch::zeros({4, 3}, torch::kBFloat16), torch::zeros({8, 3}, torch::kBFloat16),
                                         torch::zeros({8}, torch::kBFloat16)),
                    Catch::Contains("bias must be float [8]"));
}

TEST_CASE("linear_relu: values and gradients equal LibTorch's ops on the same formula") {
  torch::manual_seed(12);
  // 700 rows: two full 256-row blocks and a partial one; 40 columns: a 32-wide group and a tail.
  for (const int64_t m : {256, 40}) {
    const int64_t n = 700, k = 80;
    INFO("M = " << m);
    const auto x0 = (torch::randn({n, k}) * 0.5).to(torch::kBFloat16);
    const auto w0 = (torch::randn({m, k}) * 0.2).to(torch::kBFloat16);
    const auto b0 = torch::randn({m}) * 0.3;
    auto upstream = torch::randn({n, m}).to(torch::kBFloat16);
    const auto reference_y = torch::relu(torch::mm(x0, w0.t()).to(torch::kFloat) + b0).to(torch::kBFloat16);
    // A NaN gradient where the output is positive (it passes, as LibTorch's threshold_backward lets
    // it) and one where the output is 0 in another column (it is masked).
    const auto positive = torch::nonzero(reference_y > 0)[0], zero = torch::nonzero(reference_y == 0);
    const int64_t nan_row = positive[0].item<int64_t>(), nan_col = positive[1].item<int64_t>();
    const auto masked = zero.index({zero.select(1, 1) != nan_col})[0];
    const int64_t masked_col = masked[1].item<int64_t>();
    upstream[nan_row][nan_col] = std::nan("");
    upstream[masked[0].item<int64_t>()][masked_col] = std::nan("");

    const auto run = [&](bool reference) {
      const auto x = x0.clone().requires_grad_(true), w = w0.clone().requires_grad_(true),
                 b = b0.clone().requires_grad_(true);
      const auto y = reference ? torch::relu(torch::mm(x, w.t()).to(torch::kFloat) + b).to(torch::kBFloat16)
                               : handscs::linear_relu(x, w, b);
      const auto grads = torch::autograd::grad({y}, {x, w, b}, {upstream});
      return std::vector<torch::Tensor>{y.detach(), grads[0], grads[1], grads[2]};
    };
    const auto want = run(true);
    REQUIRE(torch::isnan(want[3][nan_col]).item<bool>());  // the NaN reached the reference's gradients
    REQUIRE_FALSE(torch::isnan(want[3][masked_col]).item<bool>());
    std::vector<torch::Tensor> bias_grads;
    for (const auto level : {handscs::SimdLevel::generic, handscs::SimdLevel::avx512}) {
      LevelScope scope(level);
      INFO("level " << handscs::simd_level_name(handscs::active_simd_level()));
      const auto got = run(false);
      CHECK(got[0].scalar_type() == torch::kBFloat16);
      CHECK(handscs_test::same_bits(got[0], want[0]));
      CHECK(handscs_test::same_bits(got[1], want[1]));  // input gradient (row nan_row is NaN in both)
      CHECK(torch::isnan(got[1][nan_row]).all().item<bool>());
      CHECK(handscs_test::same_bits(got[2], want[2]));  // weight gradient
      // The bias gradient: float sums of the same bf16 terms in another order.
      CHECK(got[3].scalar_type() == torch::kFloat);
      CHECK(torch::equal(torch::isnan(got[3]), torch::isnan(want[3])));
      const auto finite = torch::isfinite(want[3]);
      CHECK(torch::allclose(got[3].masked_select(finite), want[3].masked_select(finite), 1e-5, 1e-4));
      bias_grads.push_back(got[3].masked_fill(torch::isnan(got[3]), 0));
    }
    CHECK(torch::equal(bias_grads[0], bias_grads[1]));  // the levels add in the same order

    upstream[nan_row][nan_col] = 0.0;
    // The bias gradient does not depend on the thread count (fixed row blocks, summed in order).
    const auto two = run(false)[3];
    torch::Tensor one;
    {
      handscs::SingleThreadScope single;
      one = run(false)[3];
    }
    CHECK(torch::equal(one, two));

    // Without autograd: the same values, no graph.
    torch::NoGradGuard no_grad;
    const auto plain = handscs::linear_relu(x0, w0, b0);
    CHECK_FALSE(plain.requires_grad());
    CHECK(handscs_test::same_bits(plain, want[0]));
  }
}

TEST_CASE("add_bias_relu_: refuses a tensor autograd would need") {
  auto y = torch::zeros({4, 32}, torch::kBFloat16).requires_grad_(true);
  CHECK_THROWS_WITH(handscs::add_bias_relu_(y, torch::zeros({32})), Catch::Contains("y requires grad"));
}
