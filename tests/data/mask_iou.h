// Intersection over union of two masks, shared by the data tests that compare masks.
#pragma once

#include <algorithm>
#include <opencv2/core.hpp>

namespace data_test {

// IoU of the non-zero pixels of two masks of the same size (0 when both are empty).
inline double mask_iou(const cv::Mat& a, const cv::Mat& b) {
  cv::Mat inter, uni;
  cv::bitwise_and(a > 0, b > 0, inter);
  cv::bitwise_or(a > 0, b > 0, uni);
  return static_cast<double>(cv::countNonZero(inter)) / std::max(1, cv::countNonZero(uni));
}

}  // namespace data_test
