#include "io/ply_check.h"

#include <cstdio>

#include <torch/types.h>

namespace handscs {

int64_t PlyCheck::num_drawable() const {
  return drawable.defined() ? drawable.sum().item<int64_t>() : 0;
}

std::string PlyCheck::summary() const {
  const int64_t bad = total - num_drawable();
  if (bad == 0) return "";
  std::string text = std::to_string(bad) + " of " + std::to_string(total) + " Gaussians cannot be drawn (";
  for (size_t i = 0; i < defects.size(); ++i)
    text += (i ? ", " : "") + defects[i].first + " " + std::to_string(defects[i].second);
  return text + ")";
}

std::string PlyCheck::scale_warning() const {
  if (implausible_scales == 0) return "";
  char text[256];
  std::snprintf(text, sizeof(text),
                "%lld of %lld Gaussians have a scale above %g (largest %.3g): are the file's scale_* "
                "log-scales, as 3DGS writes them?",
                static_cast<long long>(implausible_scales), static_cast<long long>(total),
                kMaxPlausibleScale, largest_scale);
  return text;
}

PlyCheck check_gaussian_ply(const GaussianPly& g) {
  PlyCheck check;
  check.total = g.size();
  if (check.total == 0) {
    check.drawable = torch::zeros({0}, torch::kBool);
    return check;
  }
  const auto row_finite = [](const torch::Tensor& t) { return torch::isfinite(t).all(1); };
  const auto rotation_norm = g.rotations.norm(2, 1);
  // Opacity logits of +-inf are fine (sigmoid gives 1 or 0); NaN is not.
  const std::vector<std::pair<std::string, torch::Tensor>> ok = {
      {"NaN/Inf position", row_finite(g.means)},
      {"NaN/Inf colour", row_finite(g.f_dc)},
      {"NaN opacity", torch::logical_not(torch::isnan(g.opacity_logits))},
      {"NaN/Inf scale", row_finite(torch::exp(g.log_scales))},
      {"zero or NaN/Inf rotation", torch::isfinite(rotation_norm).logical_and(rotation_norm > 0)},
  };
  check.drawable = torch::ones({check.total}, torch::kBool);
  for (const auto& [defect, good] : ok) {
    const int64_t count = check.total - good.sum().item<int64_t>();
    if (count > 0) check.defects.emplace_back(defect, count);
    check.drawable = check.drawable.logical_and(good);
  }
  const auto largest = torch::exp(g.log_scales.to(torch::kFloat64)).amax(1).masked_fill(
      check.drawable.logical_not(), 0);
  check.implausible_scales = (largest > kMaxPlausibleScale).sum().item<int64_t>();
  check.largest_scale = largest.max().item<double>();
  return check;
}

GaussianPly select_gaussians(const GaussianPly& g, const torch::Tensor& keep) {
  const auto index = keep.nonzero().reshape({-1});
  GaussianPly out;
  out.means = g.means.index_select(0, index);
  out.f_dc = g.f_dc.index_select(0, index);
  if (g.f_rest.defined()) out.f_rest = g.f_rest.index_select(0, index);
  out.opacity_logits = g.opacity_logits.index_select(0, index);
  out.log_scales = g.log_scales.index_select(0, index);
  out.rotations = g.rotations.index_select(0, index);
  return out;
}

}  // namespace handscs
