// The offset regulariser L_reg against per-Gaussian loops: the paper's three terms by default, the
// fusion offsets as well with "all"; smooth norms equal plain norms away from zero. LPIPS on a
// schedule (lpips_every) and on a scaled crop (lpips_scale, against block means by reshaping).
#include "catch_torch.h"

#include <cmath>

#include "metrics/eval_config.h"
#include "metrics/image_tensor.h"
#include "test_support.h"
#include "train/losses.h"

namespace {

double frobenius(const torch::Tensor& m) {  // plain loop over a small tensor, double
  double sum = 0;
  const auto flat = m.reshape({-1});
  for (int64_t k = 0; k < flat.numel(); ++k) sum += flat[k].item<double>() * flat[k].item<double>();
  return std::sqrt(sum);
}

std::shared_ptr<const handscs::Lpips> shipped_lpips() {
  handscs::EvalConfig eval;
  eval.lpips.weights = handscs_test::kLpipsAlexWeights;
  return std::make_shared<const handscs::Lpips>(eval.lpips);
}

handscs::LossWeights lpips_only() {  // every other term off, lambda_3 = 0.01
  handscs::LossWeights weights;
  weights.rgb = weights.mask = weights.ssim = weights.reg = weights.consistency = 0;
  weights.lpips = 0.01;
  return weights;
}

handscs::DecodedOffsets random_offsets(int64_t n) {
  torch::manual_seed(11);
  handscs::DecodedOffsets o;
  const auto eye = torch::eye(3, torch::kFloat64).unsqueeze(0);
  o.dx = torch::randn({n, 3}, torch::kFloat64) * 1e-3;
  o.dsigma = eye + torch::randn({n, 3, 3}, torch::kFloat64) * 0.1;
  o.dc = torch::randn({n, 3}, torch::kFloat64) * 0.05;
  o.dx_f = torch::randn({n, 3}, torch::kFloat64) * 2e-3;
  o.dsigma_f = eye + torch::randn({n, 3, 3}, torch::kFloat64) * 0.2;
  o.dc_f = torch::randn({n, 3}, torch::kFloat64) * 0.1;
  return o;
}

}  // namespace

TEST_CASE("losses: L_reg has the paper's terms by default and the fusion offsets with all") {
  const int64_t n = 6;
  const auto o = random_offsets(n);
  const auto eye = torch::eye(3, torch::kFloat64);
  double paper = 0, fusion = 0;
  for (int64_t i = 0; i < n; ++i) {
    paper += frobenius(o.dx[i]) + frobenius(o.dsigma[i] - eye) + frobenius(o.dc[i]);
    fusion += frobenius(o.dx_f[i]) + frobenius(o.dsigma_f[i] - eye) + frobenius(o.dc_f[i]);
  }
  paper /= n;
  fusion /= n;
  // Smooth norms differ from plain ones by at most eps = 1e-6 per term.
  CHECK_THAT(handscs::offset_regularizer(o, handscs::LossWeights::RegTerms::paper).item<double>(), Catch::Matchers::WithinAbs(paper, 1e-5));
  CHECK_THAT(handscs::offset_regularizer(o, handscs::LossWeights::RegTerms::all).item<double>(),
             Catch::Matchers::WithinAbs(paper + fusion, 1e-5));
  CHECK(handscs::TrainConfig{}.loss.reg_terms == handscs::LossWeights::RegTerms::paper);

  const auto norms = handscs::offset_norms(o);
  REQUIRE(norms.size() == 6);
  CHECK(norms[1].first == "dsigma");
  CHECK_THAT(norms[5].second[2].item<double>(), Catch::Matchers::WithinAbs(frobenius(o.dc_f[2]), 1e-6));
}

TEST_CASE("losses: with decoded rows (train.cull) L_reg is the mean over those rows only") {
  const int64_t n = 7;
  const auto o = random_offsets(n);
  const auto eye = torch::eye(3, torch::kFloat64);
  const std::vector<int64_t> rows{1, 4, 5};
  double paper = 0;
  for (const int64_t i : rows)
    paper += frobenius(o.dx[i]) + frobenius(o.dsigma[i] - eye) + frobenius(o.dc[i]);
  paper /= double(rows.size());
  const auto value = handscs::offset_regularizer(o, handscs::LossWeights::RegTerms::paper,
                                                 torch::tensor(rows, torch::kInt64));
  CHECK_THAT(value.item<double>(), Catch::Matchers::WithinAbs(paper, 1e-5));
  // Every row given: the mean over all, bit for bit.
  CHECK(torch::equal(handscs::offset_regularizer(o, handscs::LossWeights::RegTerms::all,
                                                 torch::arange(n, torch::kInt64)),
                     handscs::offset_regularizer(o, handscs::LossWeights::RegTerms::all)));
}

TEST_CASE("losses: L_reg is finite with zero gradient at zero offsets") {
  handscs::DecodedOffsets o;
  const int64_t n = 4;
  o.dx = torch::zeros({n, 3}, torch::kFloat64).requires_grad_(true);
  o.dsigma = torch::eye(3, torch::kFloat64).expand({n, 3, 3}).clone();
  o.dc = torch::zeros({n, 3}, torch::kFloat64);
  o.dx_f = torch::zeros({n, 3}, torch::kFloat64);
  o.dsigma_f = o.dsigma.clone();
  o.dc_f = torch::zeros({n, 3}, torch::kFloat64);
  const auto value = handscs::offset_regularizer(o, handscs::LossWeights::RegTerms::all);
  value.backward();
  CHECK(value.item<double>() == 0.0);
  CHECK(torch::isfinite(o.dx.grad()).all().item<bool>());
  CHECK(o.dx.grad().abs().max().item<double>() == 0.0);
}

TEST_CASE("losses: LPIPS on every k-th step weighs k x lambda_3 there and is absent elsewhere") {
  const auto lpips = shipped_lpips();
  auto weights = lpips_only();
  weights.lpips_every = 3;
  const handscs::Objective objective(weights, lpips);
  torch::manual_seed(5);
  handscs::LossInputs in;
  in.rgb = torch::rand({40, 36, 3});
  in.target = torch::rand({40, 36, 3});
  in.alpha = torch::rand({40, 36});
  in.mask = torch::ones({40, 36});
  const double direct =
      handscs::lpips_loss(*lpips, handscs::hwc_to_bchw(in.rgb), handscs::hwc_to_bchw(in.target))
          .item<double>();
  REQUIRE(direct > 0.01);  // two random images are far apart
  const auto taken = objective.compute(in);
  CHECK_THAT(taken.terms.at("lpips"), Catch::Matchers::WithinRel(direct, 1e-6));
  CHECK_THAT(taken.total.item<double>(), Catch::Matchers::WithinRel(0.03 * direct, 1e-6));
  in.lpips_step = false;
  const auto skipped = objective.compute(in);
  CHECK(skipped.terms.count("lpips") == 0);
  CHECK(skipped.total.item<double>() == 0.0);
}

TEST_CASE("losses: train.loss.lpips_scale 0.25 scores the 4x4 means of the crop") {
  const auto lpips = shipped_lpips();
  auto weights = lpips_only();
  weights.lpips_every = 1;
  weights.lpips_scale = 0.25;  // 4x4 blocks: a bilinear resize would sample 2x2 of them instead
  const handscs::Objective objective(weights, lpips);
  torch::manual_seed(6);
  handscs::LossInputs in;
  in.rgb = torch::rand({192, 160, 3}, torch::requires_grad());
  in.target = torch::rand({192, 160, 3});
  in.alpha = torch::rand({192, 160});
  in.mask = torch::ones({192, 160});
  // Reference: each 4x4 block's mean by reshaping, then LPIPS at 48x40.
  const auto box_mean = [](const torch::Tensor& hwc) {
    return handscs::hwc_to_bchw(hwc.reshape({48, 4, 40, 4, 3}).mean({1, 3}));
  };
  const auto expected = handscs::lpips_loss(*lpips, box_mean(in.rgb.detach()), box_mean(in.target));
  const auto full =
      handscs::lpips_loss(*lpips, handscs::hwc_to_bchw(in.rgb.detach()), handscs::hwc_to_bchw(in.target));
  const auto taken = objective.compute(in);
  CHECK_THAT(taken.terms.at("lpips"), Catch::Matchers::WithinRel(expected.item<double>(), 1e-5));
  CHECK(std::abs(taken.terms.at("lpips") - full.item<double>()) > 1e-3);  // not the full-size score
  taken.total.backward();  // the scaling is differentiable: every pixel gets a gradient
  CHECK(torch::isfinite(in.rgb.grad()).all().item<bool>());
  CHECK((in.rgb.grad() != 0).all().item<bool>());
}

TEST_CASE("losses: scaled_side rounds and never returns 0") {
  CHECK(handscs::scaled_side(96, 0.5) == 48);
  CHECK(handscs::scaled_side(97, 0.5) == 49);  // 48.5 rounds away from zero
  CHECK(handscs::scaled_side(3, 0.1) == 1);
  CHECK(handscs::scaled_side(250, 1.0) == 250);
}
