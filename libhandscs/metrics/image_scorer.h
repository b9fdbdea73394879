// Scores one prediction against its ground truth with every evaluation metric (PSNR, SSIM, LPIPS),
// under inference mode. Shared by handscs-eval's folder mode and (later) its model mode.
#pragma once

#include <memory>
#include <optional>
#include <string>

#include <torch/types.h>

#include "metrics/eval_config.h"
#include "metrics/lpips.h"

namespace handscs {

struct ImageScores {
  double mse = 0;                // over H x W x 3, images in [0, 1]
  double psnr = 0;               // 10 log10(1 / mse) (+inf for identical images)
  double ssim = 0;               // EvalConfig::ssim convention
  std::optional<double> lpips;   // empty when LPIPS is skipped
};

class ImageScorer {
 public:
  // Loads the LPIPS weights when config.lpips.weights is set (throws Error naming a bad file);
  // without them LPIPS is skipped and lpips_skip_reason() says why.
  explicit ImageScorer(const EvalConfig& config);

  bool has_lpips() const { return lpips_ != nullptr; }
  const std::string& lpips_skip_reason() const { return lpips_skip_reason_; }

  // Throws Error with a one-line reason for mismatched sizes, non-finite values, values outside
  // [0, 1] (beyond 1e-5) or images smaller than the SSIM window; the caller records it as that
  // image's failure.
  ImageScores score(const torch::Tensor& pred,         // [H, W, 3] RGB in [0, 1]
                    const torch::Tensor& gt,           // [H, W, 3] RGB in [0, 1]
                    const torch::Tensor& mask = {}) const;  // [H, W] in [0, 1] or undefined

 private:
  EvalConfig config_;
  std::shared_ptr<const Lpips> lpips_;
  std::string lpips_skip_reason_;
};

}  // namespace handscs
