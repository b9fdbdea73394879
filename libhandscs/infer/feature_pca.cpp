#include "infer/feature_pca.h"

#include <algorithm>
#include <cmath>

#include <torch/types.h>
#include <torch/linalg.h>  // after types.h: it is not self-contained

#include "core/error.h"

namespace handscs {

namespace {

torch::Tensor as_rows(const torch::Tensor& x, const char* who) {
  TORCH_CHECK(x.dim() == 2 && x.size(0) > 0, who, ": expected a non-empty [N, D] tensor, got ", x.sizes());
  return x.detach().to(torch::kFloat64);
}

// A column whose standard deviation is below this share of the largest |value| in it is constant
// up to rounding (float32 features carry ~1e-7 relative noise): it is centred but not scaled.
constexpr double kConstantColumn = 1e-9;

}  // namespace

torch::Tensor Standardizer::apply(const torch::Tensor& x) const {
  return (as_rows(x, "Standardizer::apply") - mean) / scale;
}

Standardizer fit_standardizer(const torch::Tensor& x_in) {
  const auto x = as_rows(x_in, "fit_standardizer");
  Standardizer s;
  s.mean = x.mean(0);
  const auto std = (x - s.mean).pow(2).mean(0).sqrt();
  const auto magnitude = x.abs().amax(0).clamp_min(1e-300);
  s.scale = torch::where(std > kConstantColumn * magnitude, std, torch::ones_like(std));
  return s;
}

torch::Tensor PcaBasis::project(const torch::Tensor& x) const {
  return (as_rows(x, "PcaBasis::project") - mean).matmul(components.t());
}

PcaBasis fit_pca(const torch::Tensor& x_in, int64_t count) {
  const auto x = as_rows(x_in, "fit_pca");
  require(count > 0, "fit_pca: count must be positive");
  PcaBasis basis;
  basis.mean = x.mean(0);
  const auto centred = x - basis.mean;
  const auto covariance = centred.t().matmul(centred) / double(std::max<int64_t>(x.size(0) - 1, 1));
  // eigh returns ascending eigenvalues: the last K are the leading axes.
  const auto [values, vectors] = torch::linalg::eigh(covariance, "L");
  const int64_t d = x.size(1), k = std::min(count, d);
  const auto order = torch::arange(d - 1, d - 1 - k, -1, torch::kLong);
  auto components = vectors.index_select(1, order).t().contiguous();  // [K, D]
  const auto peak = components.gather(1, components.abs().argmax(1, true));  // [K, 1]
  components = components * torch::where(peak < 0, -1.0, 1.0);
  basis.components = components;
  const double total = values.clamp_min(0).sum().item<double>();
  basis.explained = values.index_select(0, order).clamp_min(0) / (total > 0 ? total : 1.0);
  return basis;
}

torch::Tensor ColourRange::apply(const torch::Tensor& x) const {
  const auto v = as_rows(x, "ColourRange::apply");
  const auto span = hi - lo;
  const auto flat = span <= 0;
  const auto scaled = (v - lo) / torch::where(flat, torch::ones_like(span), span);
  return torch::where(flat, torch::full_like(scaled, 0.5), scaled).clamp(0, 1);
}

ColourRange fit_colour_range(const torch::Tensor& x_in, double percentile) {
  const auto x = as_rows(x_in, "fit_colour_range");
  require(percentile >= 0 && percentile < 50,
          "colour percentile must be in [0, 50), got " + std::to_string(percentile));
  // numpy's default ("linear"): position q (n - 1) in the sorted column, interpolated.
  const auto sorted = std::get<0>(x.sort(0));
  const int64_t n = x.size(0);
  auto at = [&](double q) {
    const double pos = q * double(n - 1);
    const int64_t i = static_cast<int64_t>(std::floor(pos));
    const int64_t j = std::min(i + 1, n - 1);
    const double frac = pos - double(i);
    return sorted[i] * (1 - frac) + sorted[j] * frac;
  };
  return {at(percentile / 100), at(1 - percentile / 100)};
}

torch::Tensor FeatureColouring::colours(const torch::Tensor& features) const {
  auto rgb = range.apply(pca.project(standardizer.apply(features)));
  // Fewer than three axes (a feature of one or two columns): the missing channels are mid grey.
  if (rgb.size(1) < 3)
    rgb = torch::cat({rgb, torch::full({rgb.size(0), 3 - rgb.size(1)}, 0.5, rgb.options())}, 1);
  return rgb;
}

FeatureColouring fit_feature_colouring(const torch::Tensor& pooled, double percentile) {
  FeatureColouring c;
  c.standardizer = fit_standardizer(pooled);
  const auto z = c.standardizer.apply(pooled);
  c.pca = fit_pca(z, 3);
  c.range = fit_colour_range(c.pca.project(z), percentile);
  return c;
}

}  // namespace handscs
