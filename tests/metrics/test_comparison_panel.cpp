// The labelled comparison panel: the image columns are the inputs exactly, the heat map is the
// JET colour of the scaled error, the header holds text, and mismatched inputs are refused.
#include "metrics_test_utils.h"  // first: brings Catch2 in after torch (see there)

#include <opencv2/imgproc.hpp>

#include "metrics/comparison_panel.h"
#include "metrics/image_tensor.h"

namespace {

cv::Vec3b jet(uint8_t value) {
  cv::Mat one(1, 1, CV_8UC1, cv::Scalar(value)), colour;
  cv::applyColorMap(one, colour, cv::COLORMAP_JET);
  return colour.at<cv::Vec3b>(0, 0);
}

// Pixels of `region` that differ from the panel's background grey (text is drawn in white).
int text_pixels(const cv::Mat& region) {
  int count = 0;
  for (int y = 0; y < region.rows; ++y)
    for (int x = 0; x < region.cols; ++x)
      count += region.at<cv::Vec3b>(y, x) != cv::Vec3b(40, 40, 40);
  return count;
}

}  // namespace

TEST_CASE("comparison panel: columns are the inputs, the heat map the scaled error, titles drawn") {
  const int h = 60, w = 80;
  auto gen = at::detail::createCPUGenerator(3);
  const auto pred = at::rand({h, w, 3}, gen, torch::kFloat32);
  auto gt = pred.clone();
  gt.slice(0, 10, 20).slice(1, 5, 15).fill_(0);  // a 10 x 10 patch where the render is wrong
  const cv::Mat panel = handscs::comparison_panel(pred, gt, "step 2000  camera 400026  PSNR 31.2");
  const int top = handscs::comparison_panel_header_height(w);
  REQUIRE(panel.rows == h + top);
  REQUIRE(panel.cols == 3 * w);
  REQUIRE(panel.type() == CV_8UC3);
  const cv::Mat body = panel(cv::Rect(0, top, 3 * w, h));
  const cv::Mat expected_pred = handscs::rgb_tensor_to_mat(pred);
  const cv::Mat expected_gt = handscs::rgb_tensor_to_mat(gt);
  CHECK(cv::norm(body(cv::Rect(0, 0, w, h)), expected_pred, cv::NORM_INF) == 0);
  CHECK(cv::norm(body(cv::Rect(w, 0, w, h)), expected_gt, cv::NORM_INF) == 0);
  // Heat map: zero error is JET(0); in the patch the error is mean |pred| x 4, clamped to 1.
  const cv::Mat heat = body(cv::Rect(2 * w, 0, w, h));
  CHECK(heat.at<cv::Vec3b>(40, 40) == jet(0));
  for (const auto& [y, x] : std::vector<std::pair<int, int>>{{10, 5}, {15, 9}, {19, 14}}) {
    const double mean = pred[y][x].mean().item<double>();
    const auto level = static_cast<uint8_t>(std::lround(std::min(1.0, 4.0 * mean) * 255));
    INFO("pixel " << y << ", " << x << " mean " << mean);
    CHECK(heat.at<cv::Vec3b>(y, x) == jet(level));
  }
  // The caption line and each column's title put text in the header.
  const int line = top / 2;
  CHECK(text_pixels(panel(cv::Rect(0, 0, 3 * w, line))) > 20);
  for (int c = 0; c < 3; ++c) CHECK(text_pixels(panel(cv::Rect(c * w, line, w, line))) > 10);
  CHECK_THROWS_WITH(handscs::comparison_panel(pred, gt.slice(0, 0, 10), ""),
                    "comparison_panel: pred and gt must both be [H, W, 3]");
}
