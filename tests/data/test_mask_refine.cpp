// Mask refinement (intensity window and largest component) and ROI from the mask.
#include <opencv2/core.hpp>

#include "data/mask_refine.h"
#include "data/roi.h"

// Catch last: LibTorch pulls in glog, whose CHECK macro would otherwise replace Catch's.
#include <catch2/catch.hpp>

using namespace handscs;

TEST_CASE("mask refine: intensity window (low, high) is exclusive and uses (B+G+R)/3") {
  cv::Mat mask(1, 6, CV_8UC1, cv::Scalar(1));
  cv::Mat image(1, 6, CV_8UC3);
  image.at<cv::Vec3b>(0, 0) = {10, 10, 10};     // intensity 10: out (exclusive)
  image.at<cv::Vec3b>(0, 1) = {10, 10, 11};     // 31/3 > 10: in
  image.at<cv::Vec3b>(0, 2) = {199, 199, 199};  // in
  image.at<cv::Vec3b>(0, 3) = {200, 200, 200};  // out
  image.at<cv::Vec3b>(0, 4) = {0, 0, 255};      // 85: in, whatever the channel
  image.at<cv::Vec3b>(0, 5) = {100, 100, 100};  // in, but not in the mask below
  mask.at<uint8_t>(0, 5) = 0;
  MaskRefineConfig config;
  config.largest_component = false;
  refine_mask(mask, image, config);
  const std::vector<int> expected = {0, 1, 1, 0, 1, 0};
  for (int x = 0; x < 6; ++x) CHECK(mask.at<uint8_t>(0, x) == expected[x]);
  config.enabled = false;  // disabled: unchanged
  cv::Mat untouched(1, 6, CV_8UC1, cv::Scalar(1));
  refine_mask(untouched, image, config);
  CHECK(cv::countNonZero(untouched) == 6);
}

TEST_CASE("mask refine: keeps the largest 8-connected component") {
  cv::Mat mask(10, 10, CV_8UC1, cv::Scalar(0));
  mask(cv::Rect(0, 0, 3, 3)).setTo(1);  // 9 pixels
  mask(cv::Rect(5, 5, 4, 4)).setTo(1);  // 16 pixels
  mask.at<uint8_t>(4, 4) = 1;           // touches the big block diagonally: 8-connected, 17
  cv::Mat image(10, 10, CV_8UC3, cv::Scalar(100, 100, 100));
  refine_mask(mask, image, MaskRefineConfig{});
  CHECK(cv::countNonZero(mask) == 17);
  CHECK(mask.at<uint8_t>(0, 0) == 0);
  CHECK(mask.at<uint8_t>(4, 4) == 1);
}

TEST_CASE("roi: mask bounds plus margin, clipped to the image") {
  cv::Mat mask(50, 60, CV_8UC1, cv::Scalar(0));
  mask.at<uint8_t>(10, 20) = 1;
  mask.at<uint8_t>(30, 45) = 1;
  const PixelRect tight = mask_bounds(mask);
  CHECK(tight.x0 == 20);
  CHECK(tight.x1 == 46);
  CHECK(tight.y0 == 10);
  CHECK(tight.y1 == 31);
  const PixelRect roi = roi_from_mask(mask, 16);
  CHECK(roi.x0 == 4);
  CHECK(roi.x1 == 60);  // 62 clipped
  CHECK(roi.y0 == 0);   // -6 clipped
  CHECK(roi.y1 == 47);
  const PixelRect whole = roi_from_mask(cv::Mat(50, 60, CV_8UC1, cv::Scalar(0)), 16);
  CHECK(whole.width() == 60);
  CHECK(whole.height() == 50);
}
