// Region metrics: PSNR, SSIM and LPIPS inside region masks against per-pixel loops written here,
// the full-image invariants (a region covering everything scores as the full image), empty
// regions, and the spatial LPIPS map (its mean is the scalar LPIPS; it stays within the per-cell
// weight factors of the official bilinear map).
#include "metrics_test_utils.h"  // first: brings Catch2 in after torch (see there)

#include <cmath>

#include "metrics/image_scorer.h"
#include "metrics/lpips.h"
#include "metrics/lpips_spatial.h"
#include "metrics/psnr.h"
#include "metrics/region_means.h"
#include "metrics/ssim.h"

using Catch::Matchers::WithinAbs;
using Catch::Matchers::WithinRel;

namespace {

constexpr int64_t kH = 16, kW = 20;

using metrics_test::random_hwc;

// Four hand-made regions on kH x kW: a rectangle, a checkerboard with a hole, one pixel, nothing.
torch::Tensor hand_made_regions() {
  auto regions = torch::zeros({4, kH, kW}, torch::kBool);
  for (int64_t i = 3; i < 9; ++i)
    for (int64_t j = 2; j < 15; ++j) regions[0][i][j] = true;
  for (int64_t i = 0; i < kH; ++i)
    for (int64_t j = 0; j < kW; ++j) regions[1][i][j] = (i + j) % 2 == 0 && !(i == 4 && j == 6);
  regions[2][15][19] = true;  // a corner pixel: outside the "valid" SSIM map
  return regions;
}

handscs::EvalConfig ssim_variant(const std::string& name) {
  handscs::EvalConfig config;
  config.ssim = metrics_test::ssim_variant_config(name);
  return config;
}

// Mean over the region's pixels (all channels) of `map` [C, h, w], the map centred on kH x kW.
std::optional<double> loop_mean(const torch::Tensor& map, const torch::Tensor& region) {
  const auto m = map.to(torch::kDouble).contiguous();
  const int64_t offset_i = (region.size(0) - m.size(1)) / 2, offset_j = (region.size(1) - m.size(2)) / 2;
  double sum = 0;
  int64_t count = 0;
  for (int64_t i = 0; i < m.size(1); ++i)
    for (int64_t j = 0; j < m.size(2); ++j) {
      if (!region[i + offset_i][j + offset_j].item<bool>()) continue;
      for (int64_t c = 0; c < m.size(0); ++c) sum += m[c][i][j].item<double>();
      count += m.size(0);
    }
  if (count == 0) return std::nullopt;
  return sum / count;
}

}  // namespace

TEST_CASE("region PSNR equals a per-pixel loop over the region's pixels", "[regions]") {
  const auto gt = random_hwc(kH, kW, 11);
  const auto pred = (gt + 0.1 * (random_hwc(kH, kW, 12) - 0.5)).clamp(0, 1);
  const auto regions = hand_made_regions();
  const handscs::ImageScorer scorer{handscs::EvalConfig{}};
  const auto scores = scorer.score(pred, gt, {}, regions);
  REQUIRE(scores.regions.size() == 4);
  const auto p = pred.to(torch::kDouble), g = gt.to(torch::kDouble);
  for (int r = 0; r < 4; ++r) {
    INFO("region " << r);
    double sum = 0;
    int64_t pixels = 0;
    for (int64_t i = 0; i < kH; ++i)
      for (int64_t j = 0; j < kW; ++j) {
        if (!regions[r][i][j].item<bool>()) continue;
        ++pixels;
        for (int64_t c = 0; c < 3; ++c) {
          const double d = p[i][j][c].item<double>() - g[i][j][c].item<double>();
          sum += d * d;
        }
      }
    const auto& region = scores.regions[r];
    CHECK(region.pixels == pixels);
    CHECK(region.fraction == static_cast<double>(pixels) / (kH * kW));
    if (pixels == 0) {
      CHECK_FALSE(region.mse.has_value());
      CHECK_FALSE(region.psnr.has_value());
      CHECK_FALSE(region.ssim.has_value());
      continue;
    }
    const double mse = sum / (3.0 * pixels);
    REQUIRE(region.psnr.has_value());
    CHECK_THAT(*region.mse, WithinRel(mse, 1e-12));
    CHECK_THAT(*region.psnr, WithinAbs(10 * std::log10(1 / mse), 1e-10));
  }
  // Region 0 is 6 x 13 of 16 x 20 pixels; no LPIPS weights here, so no LPIPS either.
  CHECK(scores.regions[0].pixels == 78);
  CHECK_FALSE(scores.regions[0].lpips.has_value());
}

TEST_CASE("region scores of a region covering the image are the full-image scores", "[regions]") {
  const auto gt = random_hwc(kH, kW, 21);
  const auto pred = (gt + 0.2 * (random_hwc(kH, kW, 22) - 0.5)).clamp(0, 1);
  const auto everything = torch::ones({1, kH, kW}, torch::kBool);
  for (const std::string variant : {"3dgs", "valid", "matlab"}) {
    INFO("ssim variant " << variant);
    const handscs::ImageScorer scorer(ssim_variant(variant));
    const auto scores = scorer.score(pred, gt, {}, everything);
    const auto& region = scores.regions.at(0);
    CHECK(region.fraction == 1.0);
    CHECK_THAT(*region.mse, WithinRel(scores.mse, 1e-12));
    CHECK_THAT(*region.psnr, WithinAbs(scores.psnr, 1e-10));
    const double full = handscs::ssim(handscs::hwc_to_bchw(pred.to(torch::kDouble)),
                                      handscs::hwc_to_bchw(gt.to(torch::kDouble)), ssim_variant(variant).ssim)
                            .item<double>();
    CHECK_THAT(*region.ssim, WithinAbs(full, 1e-12));
    // Regions do not change the full-image scores.
    const auto plain = scorer.score(pred, gt);
    CHECK(plain.mse == scores.mse);
    CHECK(plain.ssim == scores.ssim);
  }
}

TEST_CASE("region SSIM is the mean of the SSIM map over the region's pixels", "[regions]") {
  const auto gt = random_hwc(kH, kW, 31);
  const auto pred = (gt + 0.2 * (random_hwc(kH, kW, 32) - 0.5)).clamp(0, 1);
  const auto regions = hand_made_regions();
  for (const std::string variant : {"3dgs", "valid", "matlab"}) {
    INFO("ssim variant " << variant);
    const auto config = ssim_variant(variant);
    const auto scores = handscs::ImageScorer(config).score(pred, gt, {}, regions);
    const auto map = handscs::ssim_map(handscs::hwc_to_bchw(pred.to(torch::kDouble)),
                                       handscs::hwc_to_bchw(gt.to(torch::kDouble)), config.ssim)[0];
    for (int r = 0; r < 4; ++r) {
      INFO("region " << r);
      const auto expected = loop_mean(map, regions[r]);
      REQUIRE(scores.regions[r].ssim.has_value() == expected.has_value());
      if (expected) CHECK_THAT(*scores.regions[r].ssim, WithinAbs(*expected, 1e-12));
    }
    // The corner pixel lies in the 5-pixel border the "valid" and "matlab" maps leave out: no SSIM
    // there, while its PSNR exists.
    CHECK(scores.regions[2].ssim.has_value() == (variant == "3dgs"));
    CHECK(scores.regions[2].psnr.has_value());
  }
}

TEST_CASE("region_means rejects maps that cannot be centred on the regions", "[regions]") {
  const auto regions = torch::ones({1, 16, 20}, torch::kBool);
  CHECK_THROWS_WITH(handscs::region_means(torch::zeros({1, 15, 20}), regions),
                    Catch::Contains("region_means: a 15x20 map cannot be centred on 16x20 regions"));
  CHECK_THROWS_WITH(handscs::region_means(torch::zeros({1, 16, 20}), torch::ones({1, 16, 20})),
                    Catch::Contains("region_means: regions must be [R, H, W] bool"));
}

TEST_CASE("upsample_mean_preserving keeps the mean of any map exactly", "[regions][lpips]") {
  at::manual_seed(5);
  // Ratios of the LPIPS taps: non-integer (127 -> 512, 31 -> 334), small, integer, and identity.
  const std::vector<std::array<int64_t, 4>> sizes = {{127, 83, 512, 334}, {31, 20, 512, 334},
                                                     {3, 5, 7, 11}, {4, 4, 16, 8}, {6, 9, 6, 9}};
  for (const auto& [h, w, height, width] : sizes) {
    INFO(h << "x" << w << " -> " << height << "x" << width);
    const auto map = torch::rand({2, 1, h, w}, torch::kDouble);
    const auto up = handscs::upsample_mean_preserving(map, height, width);
    REQUIRE(up.sizes() == at::IntArrayRef({2, 1, height, width}));
    for (int b = 0; b < 2; ++b)
      CHECK_THAT(up[b].mean().item<double>(), WithinRel(map[b].mean().item<double>(), 1e-12));
  }
  // Against the definition with a dense upsampling matrix U (columns: upsampled one-hot maps):
  // U (d / c), c = column sums of U times h w / (H W).
  const int64_t h = 3, w = 5, height = 7, width = 11;
  const auto one_hots = torch::eye(h * w, torch::kDouble).view({h * w, 1, h, w});
  const auto dense = at::upsample_bilinear2d(one_hots, {height, width}, false).view({h * w, height * width}).t();
  const auto c = dense.sum(0) * (double(h * w) / double(height * width));
  const auto d = torch::rand({h * w}, torch::kDouble);
  const auto expected = dense.matmul(d / c).view({1, 1, height, width});
  const auto up = handscs::upsample_mean_preserving(d.view({1, 1, h, w}), height, width);
  CHECK((up - expected).abs().max().item<double>() < 1e-12);
  // Small maps: per-cell weights far from 1 (0.98 and 1.04 for 3 -> 7).
  CHECK(c.max().item<double>() > 1.03);
  CHECK_THROWS_WITH(handscs::upsample_mean_preserving(torch::zeros({1, 1, 8, 8}), 4, 8),
                    Catch::Contains("upsample_mean_preserving: map 8x8 cannot be upsampled to 4x8"));
}

TEST_CASE("the spatial LPIPS map's mean is the scalar LPIPS", "[regions][lpips]") {
  const auto lpips = metrics_test::load_alex();
  for (const std::string name : {"I03", "I04"}) {
    INFO(name);
    const auto ref = metrics_test::load_pair_image("ref", name);
    const auto dist = metrics_test::load_pair_image("dist", name);
    const auto map = handscs::lpips_distance_map(lpips, dist, ref);
    REQUIRE(map.sizes() == at::IntArrayRef({1, 1, 384, 512}));
    const double scalar = lpips.distance(dist, ref).item<double>();
    CHECK_THAT(map.to(torch::kDouble).mean().item<double>(), WithinRel(scalar, 2e-6));
    // Against the official spatial=True map (plain bilinear upsampling of each tap, summed): the
    // per-cell weights at 384x512 are within 0.9988-1.0038.
    torch::Tensor official;
    for (const auto& layer : lpips.layer_distances(dist, ref)) {
      const auto up = at::upsample_bilinear2d(layer, {384, 512}, false);
      official = official.defined() ? official + up : up;
    }
    CHECK((map / official - 1).abs().max().item<double>() < 5e-3);
  }
  const auto x = metrics_test::smooth_image({1, 3, 67, 45}, 41, torch::kFloat);
  const auto y = metrics_test::smooth_image({1, 3, 67, 45}, 42, torch::kFloat);
  CHECK_THAT(handscs::lpips_distance_map(lpips, x, y).to(torch::kDouble).mean().item<double>(),
             WithinRel(lpips.distance(x, y).item<double>(), 2e-6));
}

TEST_CASE("region LPIPS is the mean of the spatial map over the region's pixels", "[regions][lpips]") {
  handscs::EvalConfig config;
  config.lpips.weights = metrics_test::lpips_alex_path();
  const handscs::ImageScorer scorer(config);
  const auto lpips = metrics_test::load_alex();
  const int64_t h = 64, w = 80;
  const auto gt = random_hwc(h, w, 51);
  const auto pred = (gt + 0.3 * (random_hwc(h, w, 52) - 0.5)).clamp(0, 1);
  auto regions = torch::zeros({3, h, w}, torch::kBool);
  regions[0].fill_(true);
  regions[1].narrow(0, 10, 20).narrow(1, 30, 40).fill_(true);
  const auto scores = scorer.score(pred, gt, {}, regions);
  REQUIRE(scores.lpips.has_value());
  CHECK(*scores.lpips == lpips.distance(handscs::hwc_to_bchw(pred.to(torch::kDouble)).to(torch::kFloat),
                                        handscs::hwc_to_bchw(gt.to(torch::kDouble)).to(torch::kFloat))
                             .item<double>());
  CHECK_THAT(*scores.regions[0].lpips, WithinRel(*scores.lpips, 2e-6));
  const auto map = handscs::lpips_distance_map(lpips, handscs::hwc_to_bchw(pred), handscs::hwc_to_bchw(gt))[0];
  double sum = 0;
  for (int64_t i = 10; i < 30; ++i)
    for (int64_t j = 30; j < 70; ++j) sum += map[0][i][j].item<double>();
  CHECK_THAT(*scores.regions[1].lpips, WithinRel(sum / (20 * 40), 1e-6));
  CHECK_FALSE(scores.regions[2].lpips.has_value());  // empty
}

TEST_CASE("region masks of the wrong shape or type are refused", "[regions]") {
  const auto image = random_hwc(kH, kW, 61);
  const handscs::ImageScorer scorer{handscs::EvalConfig{}};
  CHECK(metrics_test::error_of([&] { scorer.score(image, image, {}, torch::ones({2, kH, kW + 1}, torch::kBool)); }) ==
        "region masks must be [R, H, W] bool of the image size (20x16)");
  CHECK(metrics_test::error_of([&] { scorer.score(image, image, {}, torch::ones({2, kH, kW})); }) ==
        "region masks must be [R, H, W] bool of the image size (20x16)");
}
