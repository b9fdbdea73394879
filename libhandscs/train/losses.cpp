#include "train/losses.h"

#include <algorithm>
#include <cmath>

#include <torch/types.h>

#include "metrics/image_tensor.h"
#include "metrics/ssim.h"

namespace handscs {

namespace {
// sqrt(|v|^2 + eps^2) - eps: equals |v| up to eps, zero at zero, and differentiable there (the
// decoders start with exactly zero offsets). eps = 1e-6 is far below any offset that matters.
torch::Tensor smooth_norm(const torch::Tensor& v, int64_t first_dim) {
  constexpr double kEps = 1e-6;
  std::vector<int64_t> dims;
  for (int64_t d = first_dim; d < v.dim(); ++d) dims.push_back(d);
  return (v.pow(2).sum(dims) + kEps * kEps).sqrt() - kEps;
}

// [B, C, H, W] scaled by `scale` in area mode (adaptive average pooling; scale 1: unchanged).
torch::Tensor area_scaled(const torch::Tensor& bchw, double scale) {
  if (scale == 1.0) return bchw;
  const int64_t height = scaled_side(bchw.size(2), scale), width = scaled_side(bchw.size(3), scale);
  return torch::adaptive_avg_pool2d(bchw, {height, width});
}
}  // namespace

int64_t scaled_side(int64_t side, double scale) {
  return std::max<int64_t>(1, std::llround(static_cast<double>(side) * scale));
}

std::vector<std::pair<std::string, torch::Tensor>> offset_norms(const DecodedOffsets& o) {
  const auto eye = torch::eye(3, o.dsigma.options()).unsqueeze(0);
  return {{"dx", smooth_norm(o.dx, 1)},           {"dsigma", smooth_norm(o.dsigma - eye, 1)},
          {"dc", smooth_norm(o.dc, 1)},           {"dx_f", smooth_norm(o.dx_f, 1)},
          {"dsigma_f", smooth_norm(o.dsigma_f - eye, 1)}, {"dc_f", smooth_norm(o.dc_f, 1)}};
}

torch::Tensor offset_regularizer(const DecodedOffsets& o, LossWeights::RegTerms terms,
                                 const torch::Tensor& rows) {
  const auto norms = offset_norms(o);
  // The paper's terms are the first three (geometry and appearance offsets).
  const size_t count = terms == LossWeights::RegTerms::paper ? 3 : norms.size();
  auto per_gaussian = norms[0].second;
  for (size_t k = 1; k < count; ++k) per_gaussian = per_gaussian + norms[k].second;
  return (rows.defined() ? per_gaussian.index_select(0, rows) : per_gaussian).mean();
}

Objective::Objective(const LossWeights& weights, std::shared_ptr<const Lpips> lpips)
    : weights_(weights), lpips_(std::move(lpips)) {}

namespace {

// A loss being summed: its weighted parts, in order, and each term's unweighted value.
struct LossParts {
  LossResult result;
  std::vector<torch::Tensor> parts;
  void add(const char* name, double weight, const torch::Tensor& value) {
    result.terms[name] = value.item<double>();
    parts.push_back(weight * value);
  }
  LossResult total(const torch::TensorOptions& options) {
    result.total = parts.empty() ? torch::zeros({}, options) : parts[0];
    for (size_t i = 1; i < parts.size(); ++i) result.total = result.total + parts[i];
    return result;
  }
};

void add_pose_terms(const LossWeights& weights, const LossInputs& in, LossParts& parts) {
  if (weights.reg > 0 && in.offsets)
    parts.add("reg", weights.reg, offset_regularizer(*in.offsets, weights.reg_terms, in.decoded_rows));
  if (weights.consistency > 0 && in.consistency.defined())
    parts.add("consistency", weights.consistency, in.consistency);
}

}  // namespace

LossResult Objective::pose_terms(const LossInputs& in) const {
  LossParts parts;
  add_pose_terms(weights_, in, parts);
  return parts.total(torch::TensorOptions().dtype(torch::kFloat32));
}

LossResult Objective::compute(const LossInputs& in) const {
  LossParts loss;
  auto add = [&](const char* name, double weight, const torch::Tensor& value) { loss.add(name, weight, value); };
  if (weights_.rgb > 0) add("rgb", weights_.rgb, (in.rgb - in.target).abs().mean());
  if (weights_.mask > 0) add("mask", weights_.mask, (in.alpha - in.mask).pow(2).mean());
  const bool lpips = uses_lpips() && in.lpips_step;
  if (weights_.ssim > 0 || lpips) {
    const auto pred = hwc_to_bchw(in.rgb);
    const auto target = hwc_to_bchw(in.target);
    if (weights_.ssim > 0) add("ssim", weights_.ssim, ssim_loss(pred, target, SsimConfig{SsimConfig::Variant::three_dgs}));
    if (lpips)
      add("lpips", weights_.lpips * static_cast<double>(weights_.lpips_every),
          lpips_loss(*lpips_, area_scaled(pred, weights_.lpips_scale),
                     area_scaled(target, weights_.lpips_scale)));
  }
  add_pose_terms(weights_, in, loss);
  return loss.total(in.rgb.options());
}

}  // namespace handscs
