// A picture that says what it shows: render | ground truth | error heat map side by side, each
// column titled, and a caption line (step, camera, frame, PSNR: whatever the caller knows) above.
// The error column is the mean absolute RGB error per pixel, x4, in OpenCV's JET colour map.
#pragma once

#include <string>

#include <opencv2/core.hpp>
#include <torch/types.h>

namespace handscs {

// The heat map's gain: an error of 1/4 of the range is full scale, so errors of a few levels show.
constexpr double kPanelErrorGain = 4.0;

// pred, gt: [H, W, 3] RGB in [0, 1] (clamped). Returns an 8-bit BGR image of width 3 W and
// height H + the header's height (comparison_panel_header_height(W)); the three image columns are
// exactly rgb_tensor_to_mat(pred), rgb_tensor_to_mat(gt) and the heat map.
cv::Mat comparison_panel(const torch::Tensor& pred, const torch::Tensor& gt,
                         const std::string& caption);

// Height of the header strip (caption and column titles) for images `width` pixels wide.
int comparison_panel_header_height(int width);

}  // namespace handscs
