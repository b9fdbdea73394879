// Region of interest of a frame: the mask's bounding box grown by a margin and clipped to the
// image, so the training step renders and compares only the hand's pixels.
#pragma once

#include <opencv2/core/mat.hpp>

#include "core/camera.h"

namespace handscs {

// Tight bounding box [x0, x1) x [y0, y1) of the non-zero pixels of a CV_8UC1 mask (empty if none).
PixelRect mask_bounds(const cv::Mat& mask);

// Bounding box grown by `margin` pixels on every side, clipped to width x height.
PixelRect grow_rect(const PixelRect& rect, int margin, int width, int height);

// ROI of a mask: grow_rect(mask_bounds(mask), margin); the whole image when the mask is empty.
PixelRect roi_from_mask(const cv::Mat& mask, int margin);

}  // namespace handscs
