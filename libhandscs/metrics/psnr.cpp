#include "metrics/psnr.h"

#include <cmath>
#include <limits>

#include <ATen/ATen.h>

#include "core/error.h"

namespace handscs {

torch::Tensor mse_per_image(const torch::Tensor& x, const torch::Tensor& y) {
  TORCH_CHECK(x.dim() == 4, "mse_per_image: images must be [B, C, H, W], got ", x.sizes());
  TORCH_CHECK(x.sizes() == y.sizes(), "mse_per_image: image sizes differ: ", x.sizes(), " vs ",
              y.sizes());
  return (x - y).square().mean({1, 2, 3});
}

torch::Tensor psnr(const torch::Tensor& x, const torch::Tensor& y) {
  return -10.0 * at::log10(mse_per_image(x, y));
}

double psnr_from_mse(double mse) {
  if (mse == 0) return std::numeric_limits<double>::infinity();
  return -10.0 * std::log10(mse);
}

PsnrSummary summarize_psnr(const std::vector<double>& mse) {
  require(!mse.empty(), "summarize_psnr: no images");
  PsnrSummary summary;
  summary.count = static_cast<int64_t>(mse.size());
  for (double m : mse) {
    summary.mean_psnr += psnr_from_mse(m);
    summary.pooled_mse += m;
  }
  summary.mean_psnr /= summary.count;
  summary.pooled_mse /= summary.count;
  summary.pooled_psnr = psnr_from_mse(summary.pooled_mse);
  return summary;
}

}  // namespace handscs
