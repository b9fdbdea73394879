// SSIM (Wang et al. 2004) with an 11x11 Gaussian window (sigma 1.5), differentiable; 1 - SSIM is a loss.
// ssim = (2 mu_x mu_y + C1)(2 s_xy + C2) / ((mu_x^2 + mu_y^2 + C1)(s_xx + s_yy + C2)), C1 = 0.01^2, C2 = 0.03^2.
//
// Variants (SsimConfig::variant):
//   "3dgs"   zero padding 5, mean over the full map of every channel (graphdeco 3DGS loss_utils.ssim);
//   "valid"  no padding, mean over the valid map (skimage structural_similarity with
//            gaussian_weights=True, use_sample_covariance=False, data_range=1);
//   "matlab" MATLAB's ssim.m on rgb2gray: RGB quantised to uint8, gray = round(0.298936021293775 R +
//            0.587043074451121 G + 0.114020904255103 B), "valid" window, L = 255 (not differentiable).
// Images are [B, C, H, W] in [0, 1] (C = 3 for "matlab"); the results are per image.
#pragma once

#include <string>
#include <vector>

#include <torch/types.h>

namespace handscs {

struct SsimConfig {
  enum class Variant { three_dgs, valid, matlab };
  Variant variant = Variant::three_dgs;  // 3dgs, valid or matlab (see above)

  template <class V>
  void visit(V& v) {
    v.choice("variant", variant,
             {{"3dgs", Variant::three_dgs}, {"valid", Variant::valid}, {"matlab", Variant::matlab}},
             "SSIM convention: 3dgs (zero padding, training loss), valid (skimage), matlab (gray uint8)");
  }
};

// Window and constants shared by every variant (Wang et al. 2004; all reference tools use them).
constexpr int64_t kSsimWindow = 11;   // 11x11 Gaussian window
constexpr double kSsimSigma = 1.5;    // its standard deviation in pixels
constexpr double kSsimK1 = 0.01;      // C1 = (K1 L)^2 with L = 1 for images in [0, 1]
constexpr double kSsimK2 = 0.03;      // C2 = (K2 L)^2

// SSIM map: [B, C, H, W] for "3dgs", [B, C, H-10, W-10] for "valid", [B, 1, H-10, W-10] for "matlab".
torch::Tensor ssim_map(const torch::Tensor& x,  // [B, C, H, W] in [0, 1]
                       const torch::Tensor& y,  // [B, C, H, W] in [0, 1]
                       const SsimConfig& config = {});

// Mean SSIM per image: [B]. Differentiable for "3dgs" and "valid".
torch::Tensor ssim(const torch::Tensor& x,  // [B, C, H, W] in [0, 1]
                   const torch::Tensor& y,  // [B, C, H, W] in [0, 1]
                   const SsimConfig& config = {});

// Training loss 1 - mean_b ssim(pred_b, target_b): a scalar.
torch::Tensor ssim_loss(const torch::Tensor& pred,    // [B, C, H, W] in [0, 1]
                        const torch::Tensor& target,  // [B, C, H, W] in [0, 1]
                        const SsimConfig& config = {});

// MATLAB rgb2gray of the uint8-quantised image, returned as gray/255: [B, 1, H, W] in double.
torch::Tensor rgb_to_gray_matlab(const torch::Tensor& rgb);  // [B, 3, H, W] in [0, 1]

}  // namespace handscs
