// An image file's pixel size as its header states it, read before anything decodes it: a PNG's
// IHDR chunk, a JPEG's frame header (SOFn). A header claiming 30000 x 30000 pixels made decoders
// allocate gigabytes before any check, so image reads refuse sizes over kMaxCameraPixels first.
#pragma once

#include <cstdint>
#include <string>

namespace handscs {

struct ImageHeaderSize {
  bool known = false;  // false: not a PNG or JPEG, or no size in the bytes given
  int64_t width = 0, height = 0;
};

// The size a PNG or JPEG header states (known = false for other data or a header cut short).
ImageHeaderSize image_header_size(const std::string& file_bytes);

// Throws Error naming `path` when the header states more than kMaxCameraPixels pixels.
void refuse_oversized_image_header(const std::string& file_bytes, const std::string& path);

}  // namespace handscs
