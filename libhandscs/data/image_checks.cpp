#include "data/image_checks.h"

#include <algorithm>
#include <cstdlib>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "core/image_header.h"
#include "core/jpeg_damage.h"

namespace handscs {

bool is_monochrome(const cv::Mat& bgr) {
  if (bgr.empty()) return false;
  if (bgr.channels() == 1) return true;
  if (bgr.type() != CV_8UC3) return false;
  size_t coloured = 0;
  for (int y = 0; y < bgr.rows; ++y) {
    const uint8_t* row = bgr.ptr<uint8_t>(y);
    for (int x = 0; x < bgr.cols; ++x) {
      const int b = row[3 * x], g = row[3 * x + 1], r = row[3 * x + 2];
      const int spread = std::max({b, g, r}) - std::min({b, g, r});
      coloured += spread > kColourSpread;
    }
  }
  return static_cast<double>(coloured) < kMonochromeFraction * static_cast<double>(bgr.total());
}

bool is_black(const cv::Mat& image, int level) {
  if (image.empty()) return false;
  double max_value = 0;
  cv::minMaxLoc(image.reshape(1), nullptr, &max_value);
  return max_value <= level;
}

ImageScan scan_image(const std::string& path) {
  ImageScan scan;
  try {
    JpegThumbnail thumbnail;  // the damage check's own 1/8 decode: a JPEG is decoded once
    const std::string bytes = read_image_file(path, scan.damage, &thumbnail);
    if (!scan.damage.empty()) return scan;
    cv::Mat small;
    if (!thumbnail.bgr.empty()) {
      // A JPEG without Exif data: its header states the size a full decode gives.
      const ImageHeaderSize size = image_header_size(bytes);
      scan.width = static_cast<int>(size.width);
      scan.height = static_cast<int>(size.height);
      small = cv::Mat(thumbnail.height, thumbnail.width, CV_8UC3, thumbnail.bgr.data());
    } else {
      // The full decode a capture load makes (Exif orientation applied), reduced here: OpenCV's
      // 1/8 decode of a PNG is a full decode too, resized to floor(side / 8), so its size could
      // not be compared with a JPEG's ceil(side / 8) (167 px: 20 against 21).
      const cv::Mat encoded(1, static_cast<int>(bytes.size()), CV_8UC1, const_cast<char*>(bytes.data()));
      const cv::Mat full = cv::imdecode(encoded, cv::IMREAD_COLOR);
      if (full.empty()) return scan;
      scan.width = full.cols;
      scan.height = full.rows;
      cv::resize(full, small, cv::Size((full.cols + 7) / 8, (full.rows + 7) / 8), 0, 0, cv::INTER_AREA);
    }
    if (small.empty()) return scan;
    scan.readable = true;
    scan.black = is_black(small);
    scan.monochrome = !scan.black && is_monochrome(small);
  } catch (const OversizedImageHeader& e) {
    scan.oversized = e.problem;  // refused before any decode: a decoder would allocate gigabytes
  } catch (const std::exception&) {
    scan.readable = false;  // a corrupt file makes libjpeg/OpenCV throw: report, never propagate
  }
  return scan;
}

}  // namespace handscs
