// PNG files the tools write (renders, alpha masks, validation and side-by-side images): encoded in
// memory and written atomically, so a crash never leaves a torn image where a user looks for one.
#pragma once

#include <opencv2/core/mat.hpp>
#include <string>

#include <torch/types.h>

namespace handscs {

// Writes `image` (8-bit grey or BGR, OpenCV's order) to `path`, creating its folder. Throws Error
// naming the path when encoding or writing fails.
void write_png(const std::string& path, const cv::Mat& image);

// [H, W] (grey) or [H, W, 3] (RGB) float image in [0, 1], clamped and rounded to 8 bits.
void write_png(const std::string& path, const torch::Tensor& image);

}  // namespace handscs
