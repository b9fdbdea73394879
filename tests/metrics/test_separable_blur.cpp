// separable_blur: values and vector-Jacobian products against a dense conv2d reference, the
// reference itself against finite differences, and the input checks.
#include "metrics_test_utils.h"  // first: brings Catch2 in after torch (see there)

#include <vector>

#include "core/simd_level.h"
#include "metrics/separable_blur.h"

namespace {

// Reference: one depthwise conv2d with the dense K x K outer-product kernel.
torch::Tensor blur_reference(const torch::Tensor& input, const torch::Tensor& taps, int64_t pad) {
  const int64_t channels = input.size(1), k = taps.size(0);
  const auto kernel = (taps.view({k, 1}) * taps.view({1, k})).expand({channels, 1, k, k}).contiguous();
  return at::conv2d(input, kernel, {}, 1, pad, 1, channels);
}

// Reference in plain scalar loops: every output is 0 + w_k x_k over its in-image taps in ascending
// k, rows first, then columns. The kernels promise exactly these values at every SIMD level.
template <typename T>
torch::Tensor blur_scalar(const torch::Tensor& input, const torch::Tensor& taps_in, int64_t pad) {
  const auto in = input.contiguous();
  const auto taps_t = taps_in.contiguous();
  const T* taps = taps_t.data_ptr<T>();
  const int64_t k_n = taps_t.size(0), planes = in.size(0) * in.size(1), h = in.size(2), w = in.size(3);
  const int64_t out_h = h + 2 * pad - k_n + 1, out_w = w + 2 * pad - k_n + 1;
  std::vector<T> temp(planes * h * out_w);
  auto out = torch::empty({in.size(0), in.size(1), out_h, out_w}, in.options());
  const T* ip = in.data_ptr<T>();
  T* op = out.data_ptr<T>();
  // Output `at` of a line of `length` values `stride` apart: taps inside the line, ascending k.
  auto tap_sum = [&](const T* line, int64_t stride, int64_t length, int64_t at) {
    T acc = T(0);
    for (int64_t k = 0; k < k_n; ++k) {
      const int64_t src = at + k - pad;
      if (src >= 0 && src < length) acc += taps[k] * line[src * stride];
    }
    return acc;
  };
  for (int64_t p = 0; p < planes; ++p) {
    for (int64_t r = 0; r < h; ++r)  // rows
      for (int64_t x = 0; x < out_w; ++x)
        temp[(p * h + r) * out_w + x] = tap_sum(ip + (p * h + r) * w, 1, w, x);
    for (int64_t y = 0; y < out_h; ++y)  // then columns
      for (int64_t x = 0; x < out_w; ++x)
        op[(p * out_h + y) * out_w + x] = tap_sum(temp.data() + p * h * out_w + x, out_w, h, y);
  }
  return out;
}

}  // namespace

// Restores the SIMD level a test changed, also when a REQUIRE throws.
struct SimdLevelScope {
  handscs::SimdLevel saved = handscs::active_simd_level();
  ~SimdLevelScope() { handscs::set_simd_level(saved); }
};

TEST_CASE("separable_blur is bit-identical to the plain scalar loops at every SIMD level", "[blur]") {
  // Widths below, at and above the kernels' blocks (16 doubles, 32 floats); pads from valid to
  // K - 1 (backward of the valid SSIM); asymmetric taps, so a tap taken in the wrong order shows;
  // several threads on the large image.
  const SimdLevelScope scope;
  for (const auto level : {handscs::SimdLevel::generic, handscs::SimdLevel::avx2, handscs::SimdLevel::avx512}) {
    if (handscs::set_simd_level(level) != level) {
      WARN("SIMD level " << handscs::simd_level_name(level) << " not available on this CPU: not tested");
      continue;
    }
    for (auto dtype : {torch::kFloat, torch::kDouble})
      for (const std::vector<int64_t>& size : {std::vector<int64_t>{2, 3, 23, 17},
                                               std::vector<int64_t>{1, 1, 12, 11},
                                               std::vector<int64_t>{1, 3, 200, 333}})
        for (int64_t pad : {0, 3, 5, 8, 10}) {
          const auto input = metrics_test::smooth_image(size, 7, dtype);
          const auto taps = torch::tensor({0.1, 0.5, 0.2, 0.7, -0.3, 0.05, 0.9, 0.15, -0.2, 0.4, 0.25}, dtype);
          INFO("level " << handscs::simd_level_name(level) << ", dtype " << dtype << ", width "
                        << size[3] << ", pad " << pad);
          const auto out = handscs::separable_blur(input, taps, pad);
          const auto ref = dtype == torch::kDouble ? blur_scalar<double>(input, taps, pad)
                                                   : blur_scalar<float>(input, taps, pad);
          CHECK(torch::equal(out, ref));
        }
  }
}

TEST_CASE("gaussian_taps are the normalised 11-tap sigma 1.5 window", "[blur]") {
  const auto taps = handscs::gaussian_taps(11, 1.5, torch::kDouble);
  REQUIRE(taps.size(0) == 11);
  CHECK(taps.sum().item<double>() == Approx(1.0).epsilon(1e-15));
  // Centre tap: 1 / sum_k exp(-(k-5)^2 / 4.5) = 0.26601172...
  CHECK(taps[5].item<double>() == Approx(0.26601172486179436).epsilon(1e-12));
  CHECK(taps[0].item<double>() == Approx(taps[10].item<double>()).epsilon(1e-15));
}

TEST_CASE("separable_blur equals the dense conv2d reference (same and valid, float and double)", "[blur]") {
  for (auto dtype : {torch::kFloat, torch::kDouble}) {
    for (int64_t pad : {0, 2, 5, 10}) {
      const auto input = metrics_test::smooth_image({2, 3, 23, 17}, 3, dtype);
      const auto taps = handscs::gaussian_taps(11, 1.5, dtype);
      const auto out = handscs::separable_blur(input, taps, pad);
      const auto ref = blur_reference(input, taps, pad);
      INFO("dtype " << dtype << " pad " << pad);
      REQUIRE(out.sizes() == ref.sizes());
      const double tol = dtype == torch::kDouble ? 1e-14 : 1e-6;
      CHECK((out - ref).abs().max().item<double>() < tol);
    }
  }
}

TEST_CASE("separable_blur handles asymmetric taps and large images on several threads", "[blur]") {
  // Asymmetric taps exercise the flip in backward; 3 x 200 x 300 goes through the parallel path.
  const auto input = metrics_test::smooth_image({1, 3, 200, 300}, 4);
  const auto taps = torch::tensor({0.1, 0.5, 0.2, 0.7, -0.3}, torch::kDouble);
  const auto x = input.clone().set_requires_grad(true);
  const auto x_ref = input.clone().set_requires_grad(true);
  const auto out = handscs::separable_blur(x, taps, 1);
  const auto ref = blur_reference(x_ref, taps, 1);
  REQUIRE(out.sizes() == ref.sizes());
  CHECK((out - ref).abs().max().item<double>() < 1e-13);
  const auto cotangent = torch::randn(out.sizes(), torch::kDouble);
  const auto v = torch::autograd::grad({out}, {x}, {cotangent})[0];
  const auto v_ref = torch::autograd::grad({ref}, {x_ref}, {cotangent})[0];
  CHECK((v - v_ref).abs().max().item<double>() < 1e-12);
}

TEST_CASE("separable_blur vector-Jacobian product equals the reference's, and both pass finite differences", "[blur][gradient]") {
  for (int64_t pad : {0, 5}) {
    const auto input = metrics_test::smooth_image({1, 2, 14, 13}, 5);
    const auto taps = handscs::gaussian_taps(11, 1.5, torch::kDouble);
    at::manual_seed(11);
    const auto out_shape = blur_reference(input, taps, pad).sizes().vec();
    const auto cotangent = torch::randn(out_shape, torch::kDouble);
    auto x = input.clone().set_requires_grad(true);
    const auto v = torch::autograd::grad({handscs::separable_blur(x, taps, pad)}, {x}, {cotangent})[0];
    auto x_ref = input.clone().set_requires_grad(true);
    const auto v_ref = torch::autograd::grad({blur_reference(x_ref, taps, pad)}, {x_ref}, {cotangent})[0];
    INFO("pad " << pad);
    CHECK((v - v_ref).abs().max().item<double>() < 1e-14);
    // The reference against central differences (step 1e-6, all coordinates).
    const auto check = metrics_test::check_gradient(
        [&](const torch::Tensor& t) { return (blur_reference(t, taps, pad) * cotangent).sum(); }, input,
        1e-6, 0, 3);
    CHECK(check.relative() < 1e-6);
    // And the op itself.
    const auto op_check = metrics_test::check_gradient(
        [&](const torch::Tensor& t) { return (handscs::separable_blur(t, taps, pad) * cotangent).sum(); },
        input, 1e-6, 0, 3);
    CHECK(op_check.relative() < 1e-6);
  }
}

TEST_CASE("separable_blur rejects bad shapes, dtypes and pads", "[blur]") {
  const auto taps = handscs::gaussian_taps(11, 1.5, torch::kFloat);
  CHECK_THROWS_WITH(handscs::separable_blur(torch::zeros({3, 16, 16}), taps, 5),
                    Catch::Contains("separable_blur: input must be [B, C, H, W], got [3, 16, 16]"));
  CHECK_THROWS_WITH(handscs::separable_blur(torch::zeros({1, 1, 16, 16}, torch::kDouble), taps, 5),
                    Catch::Contains("separable_blur: taps dtype Float differs from input dtype Double"));
  CHECK_THROWS_WITH(handscs::separable_blur(torch::zeros({1, 1, 16, 16}), taps, 11),
                    Catch::Contains("separable_blur: pad must be in [0, 10], got 11"));
  CHECK_THROWS_WITH(handscs::separable_blur(torch::zeros({1, 1, 8, 16}), taps, 0),
                    Catch::Contains("separable_blur: image 8x16 is smaller than the 11-tap window (pad 0)"));
}
