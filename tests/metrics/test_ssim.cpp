// SSIM: the published MATLAB values and the reference-tool values (3DGS, skimage) of the shared
// pairs, a plain conv2d reference implementation, invariants, and gradients vs finite differences.
#include "metrics_test_utils.h"  // first: brings Catch2 in after torch (see there)

#include "metrics/ssim.h"

using Catch::Matchers::WithinAbs;

namespace {

// Reference SSIM written independently: dense 2-D Gaussian window via conv2d, moments one by one.
torch::Tensor ssim_reference(const torch::Tensor& x, const torch::Tensor& y, int64_t pad) {
  const int64_t c = x.size(1);
  std::vector<double> g(11);
  double sum = 0;
  for (int k = 0; k < 11; ++k) sum += g[k] = std::exp(-(k - 5.0) * (k - 5.0) / 4.5);
  auto taps = torch::tensor(g, torch::kDouble) / sum;
  auto window = (taps.view({11, 1}) * taps.view({1, 11})).expand({c, 1, 11, 11}).to(x.scalar_type());
  auto blur = [&](const torch::Tensor& t) { return at::conv2d(t, window, {}, 1, pad, 1, c); };
  auto mx = blur(x), my = blur(y);
  auto sxx = blur(x * x) - mx * mx, syy = blur(y * y) - my * my, sxy = blur(x * y) - mx * my;
  const double c1 = 1e-4, c2 = 9e-4;
  return ((2 * mx * my + c1) * (2 * sxy + c2)) / ((mx * mx + my * my + c1) * (sxx + syy + c2));
}

handscs::SsimConfig variant(const std::string& name) { return metrics_test::ssim_variant_config(name); }

}  // namespace

TEST_CASE("ssim matches the published and reference-tool values of the TID2013 pairs", "[ssim][oracle]") {
  struct Expected {
    std::string name;
    double matlab;  // published, 4 decimals (MATLAB ssim.m on rgb2gray uint8)
    double gs3d;    // 3DGS loss_utils.ssim, 5 decimals
    double valid;   // skimage 0.19.3, 5 decimals
  };
  const std::vector<Expected> expected = {{"I03", 0.6993, 0.68190, 0.67317},
                                          {"I04", 0.9978, 0.93119, 0.93252}};
  for (const auto& e : expected) {
    const auto ref = metrics_test::load_pair_image("ref", e.name);
    const auto dist = metrics_test::load_pair_image("dist", e.name);
    for (auto dtype : {torch::kFloat, torch::kDouble}) {
      const auto x = dist.to(dtype), y = ref.to(dtype);
      const double matlab = handscs::ssim(x, y, variant("matlab")).item<double>();
      const double gs3d = handscs::ssim(x, y, variant("3dgs")).item<double>();
      const double valid = handscs::ssim(x, y, variant("valid")).item<double>();
      INFO(e.name << " dtype " << dtype << ": matlab " << matlab << " 3dgs " << gs3d << " valid "
                  << valid);
      CHECK_THAT(matlab, WithinAbs(e.matlab, 1e-4));
      CHECK_THAT(gs3d, WithinAbs(e.gs3d, 1e-5));
      CHECK_THAT(valid, WithinAbs(e.valid, 1e-5));
    }
  }
}

TEST_CASE("ssim map equals the dense conv2d reference for both padded variants", "[ssim]") {
  const auto x = metrics_test::smooth_image({2, 3, 21, 30}, 21);
  const auto y = metrics_test::smooth_image({2, 3, 21, 30}, 22);
  const auto map_3dgs = handscs::ssim_map(x, y, variant("3dgs"));
  const auto map_valid = handscs::ssim_map(x, y, variant("valid"));
  REQUIRE(map_3dgs.sizes() == at::IntArrayRef({2, 3, 21, 30}));
  REQUIRE(map_valid.sizes() == at::IntArrayRef({2, 3, 11, 20}));
  CHECK((map_3dgs - ssim_reference(x, y, 5)).abs().max().item<double>() < 1e-12);
  CHECK((map_valid - ssim_reference(x, y, 0)).abs().max().item<double>() < 1e-12);
  // The valid map is the interior of the padded map.
  CHECK((map_valid - map_3dgs.narrow(2, 5, 11).narrow(3, 5, 20)).abs().max().item<double>() < 1e-12);
  const auto per_image = handscs::ssim(x, y, variant("3dgs"));
  REQUIRE(per_image.sizes() == at::IntArrayRef({2}));
  CHECK(per_image[1].item<double>() == Approx(map_3dgs[1].mean().item<double>()).epsilon(1e-14));
}

TEST_CASE("ssim map without autograd is bit-identical to the differentiable one", "[ssim]") {
  // Evaluation (no gradient needed) takes a direct path: one pass for the moment images, one blur
  // call, one pass for the formula. It must not move any reported SSIM.
  for (const auto dtype : {torch::kFloat64, torch::kFloat32}) {
    const auto x = metrics_test::smooth_image({2, 3, 40, 57}, 31).to(dtype);
    const auto y = metrics_test::smooth_image({2, 3, 40, 57}, 32).to(dtype);
    for (const char* name : {"3dgs", "valid", "matlab"}) {
      INFO(name << ", dtype " << dtype);
      torch::Tensor direct;
      {
        torch::NoGradGuard no_grad;
        direct = handscs::ssim_map(x, y, variant(name));
      }
      const auto graph = handscs::ssim_map(x.clone().requires_grad_(true), y, variant(name)).detach();
      REQUIRE(direct.sizes() == graph.sizes());
      CHECK(direct.scalar_type() == dtype);
      CHECK(torch::equal(direct, graph));
    }
  }
}

TEST_CASE("ssim of an image with itself is 1 and the loss is 0", "[ssim]") {
  const auto x = metrics_test::smooth_image({1, 3, 16, 16}, 23);
  for (const char* name : {"3dgs", "valid", "matlab"})
    CHECK(handscs::ssim(x, x, variant(name)).item<double>() == Approx(1.0).epsilon(1e-12));
  CHECK(std::abs(handscs::ssim_loss(x, x).item<double>()) < 1e-12);
}

TEST_CASE("rgb_to_gray_matlab quantises to uint8 and rounds the MATLAB weighted sum", "[ssim]") {
  // RGB (200, 100, 50): 0.298936*200 + 0.587043*100 + 0.114021*50 = 124.199... -> 124.
  // RGB (1, 1, 2): 0.99998... + 0.114 = 1.114 -> 1; RGB (255, 255, 255) -> 255.
  const auto rgb = torch::tensor({200.0, 1.0, 255.0, 100.0, 1.0, 255.0, 50.0, 2.0, 255.0}, torch::kDouble)
                       .view({1, 3, 1, 3}) / 255.0;
  const auto gray = handscs::rgb_to_gray_matlab(rgb) * 255.0;
  REQUIRE(gray.sizes() == at::IntArrayRef({1, 1, 1, 3}));
  CHECK(gray[0][0][0][0].item<double>() == Approx(124.0).margin(1e-9));
  CHECK(gray[0][0][0][1].item<double>() == Approx(1.0).margin(1e-9));
  CHECK(gray[0][0][0][2].item<double>() == Approx(255.0).margin(1e-9));
}

TEST_CASE("ssim loss gradients match finite differences (double, 3dgs and valid)", "[ssim][gradient]") {
  // Smooth random images keep every denominator well away from zero; SSIM is smooth there.
  for (const char* name : {"3dgs", "valid"}) {
    const auto x = metrics_test::smooth_image({2, 3, 14, 15}, 31);
    const auto y = metrics_test::smooth_image({2, 3, 14, 15}, 32);
    at::manual_seed(33);
    const auto weights = torch::rand({2}, torch::kDouble);  // random output weighting
    const auto check = metrics_test::check_gradient(
        [&](const torch::Tensor& t) { return (handscs::ssim(t, y, variant(name)) * weights).sum(); }, x,
        1e-6, 0, 4);
    INFO(name << ": max |error| " << check.max_abs_error << ", max |grad| " << check.max_abs_grad);
    CHECK(check.relative() < 1e-6);
    // ssim_loss = 1 - mean ssim, so its gradient is minus the mean's.
    const auto loss_check = metrics_test::check_gradient(
        [&](const torch::Tensor& t) { return handscs::ssim_loss(t, y, variant(name)); }, x, 1e-6, 200, 4);
    CHECK(loss_check.relative() < 1e-6);
  }
}

TEST_CASE("ssim rejects mismatched and too-small images and unknown variants", "[ssim]") {
  const auto a = torch::zeros({1, 3, 16, 16});
  CHECK_THROWS_WITH(handscs::ssim(a, torch::zeros({1, 3, 16, 17})),
                    Catch::Contains("ssim: image sizes differ: [1, 3, 16, 16] vs [1, 3, 16, 17]"));
  CHECK_THROWS_WITH(handscs::ssim(torch::zeros({1, 3, 10, 16}), torch::zeros({1, 3, 10, 16})),
                    Catch::Contains("ssim: images must be at least 11x11, got 10x16"));
  // An unknown variant cannot reach ssim(): the config reader refuses its name.
  CHECK(metrics_test::error_of([&] { variant("gaussian"); }) ==
        "ssim: variant: unknown value \"gaussian\" (known: 3dgs, valid, matlab)");
}
