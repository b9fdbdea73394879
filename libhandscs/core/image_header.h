// An image file's pixel size as its header states it, read before anything decodes it: a PNG's
// IHDR chunk, a JPEG's frame header (SOFn). A header claiming 30000 x 30000 pixels made decoders
// allocate gigabytes before any check, so image reads refuse sizes over kMaxCameraPixels first.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include "core/error.h"

namespace handscs {

struct ImageHeaderSize {
  bool known = false;  // false: not a PNG or JPEG, or no size in the bytes given
  int64_t width = 0, height = 0;
};

// The size a PNG or JPEG header states (known = false for other data or a header cut short).
ImageHeaderSize image_header_size(const std::string& file_bytes);

// The unsigned big-endian number in `count` (1-4) bytes of `file_bytes` from `at` (PNG and JPEG
// headers store their numbers so); the caller checks the bytes are there.
uint32_t big_endian_value(const std::string& file_bytes, size_t at, int count);

// What refuse_oversized_image_header throws: `problem` is what is wrong without the path ("its
// header says 30000 x 30000 pixels (900 megapixels), above the 100-megapixel limit of a camera").
class OversizedImageHeader : public Error {
 public:
  OversizedImageHeader(const std::string& path, const std::string& problem)
      : Error(path + ": " + problem), problem(problem) {}
  std::string problem;
};

// Throws OversizedImageHeader naming `path` when the header states more than kMaxCameraPixels
// pixels.
void refuse_oversized_image_header(const std::string& file_bytes, const std::string& path);

// An image file's bytes, for a decoder, read through one checked descriptor (core/atomic_file.h
// read_file). Throws Error naming the file when it is not a regular file, cannot be read, is over
// 300 MB (an uncompressed 100-megapixel RGB image, kMaxCameraPixels, is 300 MB: no image file is
// larger) or its PNG or JPEG header states more pixels than a camera may have (OversizedImageHeader).
std::string read_image_bytes(const std::string& path);

}  // namespace handscs
