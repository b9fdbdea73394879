#include "metrics/image_scorer.h"

#include <cstdio>

#include <ATen/ATen.h>
#include <c10/core/InferenceMode.h>

#include "core/error.h"
#include "metrics/image_tensor.h"
#include "metrics/lpips_spatial.h"
#include "metrics/psnr.h"
#include "metrics/region_means.h"
#include "metrics/ssim.h"

namespace handscs {

namespace {

std::string size_text(const torch::Tensor& image) {
  return std::to_string(image.size(1)) + "x" + std::to_string(image.size(0));  // W x H
}

// Float images can hold anything; every metric's constants assume the data range [0, 1].
// The slack admits rounding in float renders, not real out-of-range values.
constexpr double kRangeSlack = 1e-5;

// The common case in one vectorised pass: every value finite and inside the range. (The counts
// below take ~8 image-sized LibTorch kernels, 1.3 ms of every 512x334 score against 0.18 ms.)
template <class T>
bool plainly_valid(const torch::Tensor& image) {
  const auto contiguous = image.contiguous();
  const T* p = contiguous.data_ptr<T>();
  const int64_t n = contiguous.numel();
  T lowest = T(0), highest = T(0), non_finite = T(0);
#pragma omp simd reduction(min : lowest) reduction(max : highest) reduction(+ : non_finite)
  for (int64_t i = 0; i < n; ++i) {
    const T v = p[i];
    lowest = v < lowest ? v : lowest;
    highest = v > highest ? v : highest;
    non_finite += v - v;  // 0 for finite values, NaN for NaN and +-inf
  }
  // Bounds in the image's dtype, as LibTorch's lt / gt with a scalar compare them below.
  return non_finite == T(0) && lowest >= static_cast<T>(-kRangeSlack) &&
         highest <= static_cast<T>(1 + kRangeSlack);
}

bool plainly_valid_any(const torch::Tensor& image) {
  if (image.scalar_type() == torch::kFloat) return plainly_valid<float>(image);
  if (image.scalar_type() == torch::kDouble) return plainly_valid<double>(image);
  return false;  // other dtypes: the counts below decide
}

void check_image(const torch::Tensor& image, const char* what) {
  require(image.defined() && image.dim() == 3 && image.size(2) == 3,
          std::string(what) + " must be [H, W, 3]");
  if (image.is_cpu() && plainly_valid_any(image)) return;
  // Something is off (or the dtype is unusual): count it for the message.
  const int64_t bad = image.numel() - image.isfinite().sum().item<int64_t>();
  require(bad == 0, std::string(what) + " has " + std::to_string(bad) +
                        " non-finite values (NaN or inf)");
  const int64_t outside =
      (image.lt(-kRangeSlack) | image.gt(1 + kRangeSlack)).sum().item<int64_t>();
  if (outside > 0) {
    char range[96];
    std::snprintf(range, sizeof(range), " (min %.6g, max %.6g)", image.min().item<double>(),
                  image.max().item<double>());
    throw Error(std::string(what) + " has " + std::to_string(outside) +
                " values outside [0, 1]" + range);
  }
}

}  // namespace

ImageScorer::ImageScorer(const EvalConfig& config) : config_(config) {
  lpips_net_spec(config_.lpips.net);  // unknown names fail here, even without weights
  // Evaluation images are always in [0, 1]; "minus_one_one" would silently mean "unscaled".
  require(config_.lpips.input_range != "minus_one_one",
          "lpips.input_range: evaluation images are in [0,1]; use zero_one (official) or "
          "zero_one_unscaled");
  if (config_.lpips.weights.empty()) {
    lpips_skip_reason_ = "no LPIPS weight file given (--lpips-weights FILE or lpips.weights)";
  } else {
    lpips_ = std::make_shared<const Lpips>(config_.lpips);
  }
}

ImageScores ImageScorer::score(const torch::Tensor& pred, const torch::Tensor& gt,
                               const torch::Tensor& mask, const torch::Tensor& regions) const {
  c10::InferenceMode inference;
  check_image(pred, "prediction");
  check_image(gt, "ground truth");
  require(pred.sizes() == gt.sizes(), "size mismatch: prediction " + size_text(pred) +
                                          ", ground truth " + size_text(gt));
  require(pred.size(0) >= kSsimWindow && pred.size(1) >= kSsimWindow,
          "image " + size_text(pred) + " is smaller than the " + std::to_string(kSsimWindow) + "x" +
              std::to_string(kSsimWindow) + " SSIM window");
  auto p = pred.to(torch::kDouble);
  auto g = gt.to(torch::kDouble);
  if (mask.defined()) {
    require(mask.dim() == 2 && mask.size(0) == pred.size(0) && mask.size(1) == pred.size(1),
            "mask size differs from the images (" + size_text(pred) + ")");
    require(mask.isfinite().all().item<bool>() && mask.min().item<double>() >= 0 &&
                mask.max().item<double>() <= 1,
            "mask values must be finite and in [0, 1]");
    const auto m = mask.to(torch::kDouble).unsqueeze(2);
    const auto bg = torch::tensor({config_.background[0], config_.background[1], config_.background[2]},
                                  torch::kDouble)
                        .view({1, 1, 3});
    g = g * m + bg * (1 - m);
    if (config_.mask_mode == EvalConfig::MaskMode::composite_both) p = p * m + bg * (1 - m);
  }
  if (regions.defined())
    require(regions.dim() == 3 && regions.scalar_type() == torch::kBool &&
                regions.size(1) == pred.size(0) && regions.size(2) == pred.size(1),
            "region masks must be [R, H, W] bool of the image size (" + size_text(pred) + ")");
  const auto p4 = hwc_to_bchw(p);
  const auto g4 = hwc_to_bchw(g);
  const auto ssim_values = ssim_map(p4, g4, config_.ssim);
  ImageScores scores;
  scores.mse = mse_per_image(p4, g4).item<double>();
  scores.psnr = psnr_from_mse(scores.mse);
  scores.ssim = ssim_values.mean({1, 2, 3}).item<double>();  // as ssim()
  std::vector<torch::Tensor> lpips_layers;
  if (lpips_) {
    const auto dtype = lpips_->dtype();
    lpips_layers = lpips_->layer_distances(p4.to(dtype), g4.to(dtype));
    scores.lpips = lpips_from_layers(lpips_layers).item<double>();
  }
  if (!regions.defined()) return scores;

  const auto pixels = region_pixel_counts(regions);
  const auto mse = region_means((p4 - g4).square()[0], regions);
  const auto ssim_means = region_means(ssim_values[0], regions);
  std::vector<std::optional<double>> lpips_means(pixels.size());
  if (lpips_)
    lpips_means = region_means(lpips_map_from_layers(lpips_layers, p4.size(2), p4.size(3))[0], regions);
  for (size_t r = 0; r < pixels.size(); ++r) {
    RegionScores region;
    region.pixels = pixels[r];
    region.fraction = static_cast<double>(pixels[r]) / static_cast<double>(pred.size(0) * pred.size(1));
    region.mse = mse[r];
    if (mse[r]) region.psnr = psnr_from_mse(*mse[r]);
    region.ssim = ssim_means[r];
    region.lpips = lpips_means[r];
    scores.regions.push_back(region);
  }
  return scores;
}

}  // namespace handscs
