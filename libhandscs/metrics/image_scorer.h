// Scores one prediction against its ground truth with every evaluation metric (PSNR, SSIM, LPIPS),
// under inference mode, on the full image and inside optional region masks (region_means.h).
// Shared by handscs-eval's folder mode and its model mode.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <torch/types.h>

#include "metrics/eval_config.h"
#include "metrics/lpips.h"

namespace handscs {

// One region of one image: the full-image protocol restricted to the region's pixels. Every score
// is empty when the region is (pixels = 0); SSIM also when no region pixel lies inside the SSIM map
// ("valid"/"matlab" leave out a 5-pixel border); LPIPS also when LPIPS is skipped.
struct RegionScores {
  int64_t pixels = 0;            // region pixels in the image
  double fraction = 0;           // pixels / (H W)
  std::optional<double> mse;     // over the region's pixels x 3 channels
  std::optional<double> psnr;    // 10 log10(1 / mse)
  std::optional<double> ssim;    // mean of the SSIM map (every channel) over the region's pixels
  std::optional<double> lpips;   // mean of the spatial LPIPS map (lpips_spatial.h) over them
};

struct ImageScores {
  double mse = 0;                // over H x W x 3, images in [0, 1]
  double psnr = 0;               // 10 log10(1 / mse) (+inf for identical images)
  double ssim = 0;               // EvalConfig::ssim convention
  std::optional<double> lpips;   // empty when LPIPS is skipped
  std::vector<RegionScores> regions;  // one per plane of score()'s `regions` (none without)
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
  // image's failure. The full-image scores are the same with or without `regions`.
  ImageScores score(const torch::Tensor& pred,                // [H, W, 3] RGB in [0, 1]
                    const torch::Tensor& gt,                  // [H, W, 3] RGB in [0, 1]
                    const torch::Tensor& mask = {},           // [H, W] in [0, 1] or undefined
                    const torch::Tensor& regions = {}) const;  // [R, H, W] bool or undefined

 private:
  EvalConfig config_;
  std::shared_ptr<const Lpips> lpips_;
  std::string lpips_skip_reason_;
};

}  // namespace handscs
