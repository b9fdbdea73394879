// Image <-> tensor conventions of the metrics. Images are float RGB in [0, 1]: [H, W, 3] as the
// renderer produces them, [B, 3, H, W] for the metric functions. OpenCV images are BGR(A), any depth.
#pragma once

#include <array>
#include <string>

#include <opencv2/core.hpp>
#include <torch/types.h>

namespace handscs {

// [H, W, 3] float32 RGB in [0, 1] from an OpenCV image: 8-bit (/255), 16-bit (/65535) or 32-bit
// float (as is); 1 channel (gray, replicated), 3 (BGR) or 4 (BGRA, composited over `background`,
// RGB in [0, 1]). Throws Error for other depths or channel counts.
torch::Tensor mat_to_rgb_tensor(const cv::Mat& image, const std::array<double, 3>& background = {0, 0, 0});

// [H, W] float32 in [0, 1] from a mask image (1 channel, or colour channels that are all equal;
// an alpha channel is ignored). Throws Error for a mask with colour.
torch::Tensor mat_to_mask_tensor(const cv::Mat& mask);

// 8-bit BGR OpenCV image from [H, W, 3] RGB in [0, 1] (clamped, rounded to nearest).
cv::Mat rgb_tensor_to_mat(const torch::Tensor& rgb);  // [H, W, 3]

// Reads an image file (unchanged depth; a .jpg/.jpeg is first checked for damage) into [H, W, 3].
// `is_grey`, when given, says whether the picture is grey: one channel, or R = G = B at every
// pixel. Throws Error naming the file.
torch::Tensor load_rgb_image(const std::string& path, const std::array<double, 3>& background = {0, 0, 0},
                             bool* is_grey = nullptr);

// Reads a mask file into [H, W] in [0, 1]. Throws Error naming the file.
torch::Tensor load_mask_image(const std::string& path);

// [H, W, C] -> [1, C, H, W] and [B, H, W, C] -> [B, C, H, W] (contiguous copies).
torch::Tensor hwc_to_bchw(const torch::Tensor& image);
// [B, C, H, W] -> [B, H, W, C]; a batch of one gives [H, W, C].
torch::Tensor bchw_to_hwc(const torch::Tensor& images);

}  // namespace handscs
