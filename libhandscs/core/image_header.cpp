#include "core/image_header.h"

#include <cstdio>

#include "core/atomic_file.h"
#include "core/camera_checks.h"
#include "core/png_damage.h"

namespace handscs {

namespace {

// SOF0-SOF15 hold the frame's size, except C4 (DHT), C8 (JPG) and CC (DAC), which share the range.
bool states_frame_size(unsigned char marker) {
  return marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 && marker != 0xCC;
}

}  // namespace

uint32_t big_endian_value(const std::string& file_bytes, size_t at, int count) {
  uint32_t v = 0;
  for (int k = 0; k < count; ++k) v = (v << 8) | static_cast<unsigned char>(file_bytes[at + k]);
  return v;
}

ImageHeaderSize image_header_size(const std::string& b) {
  ImageHeaderSize size;
  if (b.size() >= 24 && is_png_data(b) && b.compare(12, 4, "IHDR") == 0) {
    size.width = big_endian_value(b, 16, 4);
    size.height = big_endian_value(b, 20, 4);
    size.known = true;
    return size;
  }
  if (b.size() < 4 || static_cast<unsigned char>(b[0]) != 0xFF ||
      static_cast<unsigned char>(b[1]) != 0xD8)
    return size;
  // Marker segments up to the frame header: FF xx, then a 2-byte length that counts itself.
  size_t at = 2;
  while (at + 4 <= b.size()) {
    if (static_cast<unsigned char>(b[at]) != 0xFF) return size;
    const unsigned char marker = static_cast<unsigned char>(b[at + 1]);
    if (marker == 0xFF) {  // fill byte
      ++at;
      continue;
    }
    const int64_t length = big_endian_value(b, at + 2, 2);
    if (states_frame_size(marker)) {
      if (at + 9 > b.size()) return size;
      size.height = big_endian_value(b, at + 5, 2);
      size.width = big_endian_value(b, at + 7, 2);
      size.known = true;
      return size;
    }
    if (marker == 0xDA || length < 2) return size;  // image data before any frame header
    at += 2 + static_cast<size_t>(length);
  }
  return size;
}

void refuse_oversized_image_header(const std::string& file_bytes, const std::string& path) {
  const ImageHeaderSize size = image_header_size(file_bytes);
  if (!size.known) return;
  const double pixels = static_cast<double>(size.width) * static_cast<double>(size.height);
  if (pixels <= kMaxCameraPixels) return;
  char text[160];
  std::snprintf(text, sizeof(text), "its header says %lld x %lld pixels (%.0f megapixels), above "
                "the %.0f-megapixel limit of a camera", static_cast<long long>(size.width),
                static_cast<long long>(size.height), pixels / 1e6, kMaxCameraPixels / 1e6);
  throw OversizedImageHeader(path, text);
}

std::string read_image_bytes(const std::string& path) {
  std::string bytes = read_file(path, std::uintmax_t{300} << 20);
  refuse_oversized_image_header(bytes, path);
  return bytes;
}

}  // namespace handscs
