#include "data/roi.h"

#include <algorithm>

namespace handscs {

PixelRect mask_bounds(const cv::Mat& mask) {
  int x0 = mask.cols, y0 = mask.rows, x1 = 0, y1 = 0;
  for (int y = 0; y < mask.rows; ++y) {
    const uint8_t* row = mask.ptr<uint8_t>(y);
    int first = -1, last = -1;
    for (int x = 0; x < mask.cols; ++x) {
      if (row[x]) {
        if (first < 0) first = x;
        last = x;
      }
    }
    if (first < 0) continue;
    x0 = std::min(x0, first);
    x1 = std::max(x1, last + 1);
    y0 = std::min(y0, y);
    y1 = y + 1;
  }
  if (x1 <= x0) return PixelRect{};
  return PixelRect{x0, y0, x1, y1};
}

PixelRect grow_rect(const PixelRect& rect, int margin, int width, int height) {
  return PixelRect{std::max(0, rect.x0 - margin), std::max(0, rect.y0 - margin),
                   std::min(width, rect.x1 + margin), std::min(height, rect.y1 + margin)};
}

PixelRect roi_from_mask(const cv::Mat& mask, int margin) {
  const PixelRect bounds = mask_bounds(mask);
  if (bounds.empty()) return PixelRect{0, 0, mask.cols, mask.rows};
  return grow_rect(bounds, margin, mask.cols, mask.rows);
}

}  // namespace handscs
