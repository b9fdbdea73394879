// A labelled picture grid (paper Fig. 1(b): rows = representation, columns = pose): equal-size
// cells side by side, column labels above, row labels on the left, in OpenCV's Hershey font.
#pragma once

#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>
#include <torch/types.h>

#include "core/camera.h"

namespace handscs {

struct LabelledGrid {
  std::string corner;                        // top-left, above the row labels ('\n' as below)
  std::vector<std::string> column_labels;
  std::vector<std::string> row_labels;       // '\n' starts another line
  std::vector<std::vector<cv::Mat>> cells;  // [row][column], 8-bit BGR, all of one size
};

// The whole grid as one 8-bit BGR image (black background, white text, grey gaps). Throws Error
// when the cells are missing or of different sizes, or the labels do not match their count.
cv::Mat compose_grid(const LabelledGrid& grid);

// The smallest rectangle holding every pixel with alpha above 1/255 in any of `alphas` ([H, W],
// all one size), grown by `margin` pixels and clipped to the image; the whole image when none is.
PixelRect coverage_box(const std::vector<torch::Tensor>& alphas, int margin);

}  // namespace handscs
