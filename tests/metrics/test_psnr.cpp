// PSNR: the published uint8 values of the shared pairs, closed forms, and the pooled-MSE summary.
#include "metrics_test_utils.h"  // first: brings Catch2 in after torch (see there)

#include <cmath>

#include "metrics/psnr.h"

using Catch::Matchers::WithinAbs;

TEST_CASE("psnr matches the published uint8 values of the TID2013 pairs", "[psnr][oracle]") {
  // values.json psnr_uint8_rgb (skimage, data_range 255, MSE over H x W x 3), 2 decimals.
  const std::vector<std::pair<std::string, double>> published = {{"I03", 21.11}, {"I04", 20.99}};
  for (const auto& [name, expected] : published) {
    const auto ref = metrics_test::load_pair_image("ref", name);
    const auto dist = metrics_test::load_pair_image("dist", name);
    REQUIRE(ref.sizes() == at::IntArrayRef({1, 3, 384, 512}));
    const double value = handscs::psnr(dist.to(torch::kDouble), ref.to(torch::kDouble)).item<double>();
    INFO(name << " psnr " << value);
    CHECK_THAT(value, WithinAbs(expected, 0.005 + 1e-9));
  }
}

TEST_CASE("psnr of a constant offset is -20 log10(offset)", "[psnr]") {
  const auto x = metrics_test::smooth_image({2, 3, 8, 9}, 1);
  const auto y = x + 0.1;
  const auto values = handscs::psnr(x, y);
  REQUIRE(values.sizes() == at::IntArrayRef({2}));
  CHECK_THAT(values[0].item<double>(), WithinAbs(20.0, 1e-9));
  CHECK_THAT(values[1].item<double>(), WithinAbs(20.0, 1e-9));
  CHECK(std::isinf(handscs::psnr(x, x)[0].item<double>()));
  CHECK(std::isinf(handscs::psnr_from_mse(0.0)));
  CHECK_THAT(handscs::psnr_from_mse(1e-3), WithinAbs(30.0, 1e-12));
}

TEST_CASE("psnr summary reports the mean PSNR and the PSNR of the pooled MSE", "[psnr]") {
  const auto summary = handscs::summarize_psnr({1e-2, 1e-4});
  CHECK(summary.count == 2);
  CHECK_THAT(summary.mean_psnr, WithinAbs(30.0, 1e-12));                 // (20 + 40) / 2
  CHECK_THAT(summary.pooled_mse, WithinAbs(0.00505, 1e-15));
  CHECK_THAT(summary.pooled_psnr, WithinAbs(-10 * std::log10(0.00505), 1e-12));
  CHECK(metrics_test::error_of([] { handscs::summarize_psnr({}); }) == "summarize_psnr: no images");
}

TEST_CASE("mse_per_image rejects images of different sizes", "[psnr]") {
  const auto x = torch::zeros({1, 3, 4, 4});
  const auto y = torch::zeros({1, 3, 4, 5});
  CHECK_THROWS_WITH(handscs::mse_per_image(x, y),
                    Catch::Contains("mse_per_image: image sizes differ: [1, 3, 4, 4] vs [1, 3, 4, 5]"));
}
