// Cheap per-image checks run when a capture is opened: readable, its size, black (camera dropout)
// and monochrome (R = G = B cameras), from a 1/8-scale JPEG decode (DCT scaling: ~4x faster than
// full); other images (PNG) are decoded in full, as OpenCV's own 1/8 decode of them does too.
#pragma once

#include <opencv2/core/mat.hpp>
#include <string>

namespace handscs {

struct ImageScan {
  bool readable = false;    // decoded without error
  std::string damage;       // a .jpg/.jpeg found damaged (core/jpeg_damage.h): what is wrong (else "")
  std::string oversized;    // a header over a camera's pixel limit (core/image_header.h): what it says
  bool black = false;       // brightest (8x8-averaged) value <= kBlackLevel
  bool monochrome = false;  // fewer than kMonochromeFraction of pixels have a channel spread > 4
  int width = 0, height = 0;  // pixels, as a full decode gives them (capture loads compare them exactly)
};

// Version of scan_image's checks: bump whenever what it reports for a file can change (a check added
// or altered, a constant below changed), so that scans cached by an earlier version are redone
// (data/scan_cache.h).
constexpr int kImageChecksVersion = 4;
// Brightest 8x8-block average of a black (dropped-out) frame: JPEG noise on a black frame stays a
// few levels above 0, a lit hand or body is several tens of levels brighter.
constexpr int kBlackLevel = 16;
// Channel spread (max - min of B, G, R) above which a pixel counts as coloured: JPEG chroma
// rounding of a grey image stays within 1-2 levels; skin and clothes differ by tens of levels.
constexpr int kColourSpread = 4;
// Fraction of coloured pixels below which an image is monochrome: real colour frames have
// 50-60% coloured pixels, monochrome cameras exactly 0 (checked on the four InterHand samples).
constexpr double kMonochromeFraction = 0.01;

// True when fewer than kMonochromeFraction of the pixels of an 8-bit BGR image are coloured.
bool is_monochrome(const cv::Mat& bgr);
// True when no pixel of an 8-bit image exceeds `level`.
bool is_black(const cv::Mat& image, int level = kBlackLevel);

// Reads `path`, checks a JPEG for damage (core/jpeg_damage.h, whose 1/8-scale decode it reuses;
// other files, and JPEGs OpenCV turns by their Exif orientation, are decoded in full and reduced
// here to ceil(side / 8) as libjpeg's scaling does) and runs the checks. Never throws (unreadable,
// damaged and oversized files report so; an oversized one is not decoded).
ImageScan scan_image(const std::string& path);

}  // namespace handscs
