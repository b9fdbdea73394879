// Which Gaussians of a 3DGS PLY can be drawn: a NaN or infinite position, colour, opacity, scale
// (after exp) or a zero / non-finite rotation makes a Gaussian undrawable. The rasterizer would drop
// such Gaussians without a word; programs report the counts and fail when nothing is left.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "io/ply.h"

namespace handscs {

// Largest plausible Gaussian scale (after exp), in the PLY's units: a hand avatar's Gaussians are
// millimetres, and 3DGS scenes in COLMAP units span tens of units; 10,000 is far beyond both, so a
// larger scale is a file whose scale_* are not log-scales (or are corrupted), drawn as a screen-
// filling smear.
constexpr double kMaxPlausibleScale = 1e4;

struct PlyCheck {
  int64_t total = 0;
  torch::Tensor drawable;  // [N] bool
  // (defect, count) in a fixed order, only defects that occur; a Gaussian may have several.
  std::vector<std::pair<std::string, int64_t>> defects;
  // Drawable Gaussians whose largest scale exceeds kMaxPlausibleScale, and the largest scale.
  int64_t implausible_scales = 0;
  double largest_scale = 0;

  int64_t num_drawable() const;
  // "" when every Gaussian can be drawn, else "N of M Gaussians cannot be drawn (defect n, ...)".
  std::string summary() const;
  // "" when no scale is implausible, else a warning naming the count and the largest scale.
  std::string scale_warning() const;
};

PlyCheck check_gaussian_ply(const GaussianPly& gaussians);

// The Gaussians where `keep` ([N] bool) is true, every attribute (f_rest too when present).
GaussianPly select_gaussians(const GaussianPly& gaussians, const torch::Tensor& keep);

}  // namespace handscs
