// PSNR for images in [0, 1]: psnr = 10 log10(1 / mse), mse = mean over H x W x C of (x - y)^2.
// A set of images reports the mean of per-image PSNR and, as well, the PSNR of the pooled MSE.
#pragma once

#include <cstdint>
#include <vector>

#include <torch/types.h>

namespace handscs {

// Mean squared error per image: [B] (differentiable).
torch::Tensor mse_per_image(const torch::Tensor& x,   // [B, C, H, W]
                            const torch::Tensor& y);  // [B, C, H, W]

// PSNR per image in dB for data range 1: [B]; +inf where the images are identical.
torch::Tensor psnr(const torch::Tensor& x,   // [B, C, H, W] in [0, 1]
                   const torch::Tensor& y);  // [B, C, H, W] in [0, 1]

// 10 log10(1 / mse); +inf for mse = 0.
double psnr_from_mse(double mse);

struct PsnrSummary {
  int64_t count = 0;         // images averaged
  double mean_psnr = 0;      // mean over images of their PSNR (what papers report)
  double pooled_mse = 0;     // mean of the per-image MSEs (all images have equal weight)
  double pooled_psnr = 0;    // PSNR of pooled_mse (robust to one perfect image)
};

// Summary of per-image MSEs (each over H x W x C). Throws Error when `mse` is empty.
PsnrSummary summarize_psnr(const std::vector<double>& mse);

}  // namespace handscs
