// Evaluation options shared by handscs-eval's modes: metric conventions, LPIPS weights and the mask
// protocol (full image, ground truth composited on the background with its mask; docs/METRICS.md).
#pragma once

#include <array>
#include <string>

#include "metrics/lpips.h"
#include "metrics/ssim.h"

namespace handscs {

struct EvalConfig {
  SsimConfig ssim;                              // SSIM convention
  LpipsConfig lpips;                            // LPIPS net and weights (none = LPIPS reported null)
  enum class MaskMode { composite_gt, composite_both };
  MaskMode mask_mode = MaskMode::composite_gt;  // what a mask does (only when masks are given)
  std::array<double, 3> background = {0, 0, 0};  // RGB in [0,1] behind masked/alpha images

  template <class V>
  void visit(V& v) {
    v.section("ssim", ssim, "SSIM options");
    v.section("lpips", lpips, "LPIPS options");
    v.choice("mask_mode", mask_mode,
             {{"composite_gt", MaskMode::composite_gt}, {"composite_both", MaskMode::composite_both}},
             "with masks: composite the ground truth (or both images) onto the background");
    v.field("background", background, "background RGB in [0,1] for masks and alpha channels");
  }
};

}  // namespace handscs
