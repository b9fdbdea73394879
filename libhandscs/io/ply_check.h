// Which Gaussians of a 3DGS PLY can be drawn: a NaN or infinite position, colour, opacity, scale
// (after exp) or a zero / non-finite rotation makes a Gaussian undrawable. The rasterizer would drop
// such Gaussians without a word; programs report the counts and fail when nothing is left.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "io/ply.h"

namespace handscs {

struct PlyCheck {
  int64_t total = 0;
  torch::Tensor drawable;  // [N] bool
  // (defect, count) in a fixed order, only defects that occur; a Gaussian may have several.
  std::vector<std::pair<std::string, int64_t>> defects;

  int64_t num_drawable() const;
  // "" when every Gaussian can be drawn, else "N of M Gaussians cannot be drawn (defect n, ...)".
  std::string summary() const;
};

PlyCheck check_gaussian_ply(const GaussianPly& gaussians);

// The Gaussians where `keep` ([N] bool) is true, every attribute (f_rest too when present).
GaussianPly select_gaussians(const GaussianPly& gaussians, const torch::Tensor& keep);

}  // namespace handscs
