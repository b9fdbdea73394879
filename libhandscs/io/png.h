// PNG files the tools write (renders, alpha masks, validation and side-by-side images): encoded in
// memory and written atomically, so a crash never leaves a torn image where a user looks for one.
#pragma once

#include <opencv2/core/mat.hpp>
#include <string>

namespace handscs {

// Writes `image` (8-bit grey or BGR, OpenCV's order) to `path`, creating its folder. Throws Error
// naming the path when encoding or writing fails.
void write_png(const std::string& path, const cv::Mat& image);

}  // namespace handscs
