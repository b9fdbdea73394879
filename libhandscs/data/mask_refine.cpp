#include "data/mask_refine.h"

#include <opencv2/imgproc.hpp>

#include "core/error.h"

namespace handscs {

void keep_largest_component(cv::Mat& mask) {
  cv::Mat labels, stats, centroids;
  const int count = cv::connectedComponentsWithStats(mask, labels, stats, centroids, 8, CV_32S);
  if (count <= 2) return;  // background plus at most one component
  int best = 1;
  for (int k = 2; k < count; ++k)
    if (stats.at<int>(k, cv::CC_STAT_AREA) > stats.at<int>(best, cv::CC_STAT_AREA)) best = k;
  for (int y = 0; y < mask.rows; ++y) {
    uint8_t* row = mask.ptr<uint8_t>(y);
    const int32_t* label = labels.ptr<int32_t>(y);
    for (int x = 0; x < mask.cols; ++x) row[x] = label[x] == best ? 1 : 0;
  }
}

void refine_mask(cv::Mat& mask, const cv::Mat& bgr, const MaskRefineConfig& config) {
  if (!config.enabled) return;
  require(mask.type() == CV_8UC1 && mask.size() == bgr.size() &&
              (bgr.type() == CV_8UC3 || bgr.type() == CV_8UC1),
          "refine_mask: mask and image sizes or types differ");
  const int channels = bgr.channels();
  for (int y = 0; y < mask.rows; ++y) {
    uint8_t* row = mask.ptr<uint8_t>(y);
    const uint8_t* pixel = bgr.ptr<uint8_t>(y);
    for (int x = 0; x < mask.cols; ++x) {
      if (!row[x]) continue;
      int sum = 0;
      for (int c = 0; c < channels; ++c) sum += pixel[x * channels + c];
      // Compare 3 * intensity with 3 * bounds: exact in integers.
      const int scaled_low = config.low * channels, scaled_high = config.high * channels;
      row[x] = (sum > scaled_low && sum < scaled_high) ? 1 : 0;
    }
  }
  if (config.largest_component) keep_largest_component(mask);
}

}  // namespace handscs
