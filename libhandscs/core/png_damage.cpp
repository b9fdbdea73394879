#include "core/png_damage.h"

#include <array>
#include <cstdint>
#include <cstring>

#include "core/image_header.h"

namespace handscs {

namespace {

constexpr char kSignature[] = "\x89PNG\r\n\x1a\n";
constexpr size_t kSignatureBytes = 8;
// A chunk's length field, type, and CRC around its data (PNG specification, section 5.3).
constexpr size_t kChunkOverhead = 12;
// The specification caps a chunk's length at 2^31 - 1.
constexpr uint32_t kMaxChunkLength = 0x7fffffffu;

// CRC-32 of the PNG specification (ISO 3309, reflected polynomial 0xEDB88320), over a chunk's
// type and data.
uint32_t crc32(const char* data, size_t size) {
  static const std::array<uint32_t, 256> table = [] {
    std::array<uint32_t, 256> t{};
    for (uint32_t n = 0; n < 256; ++n) {
      uint32_t c = n;
      for (int k = 0; k < 8; ++k) c = (c & 1) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
      t[n] = c;
    }
    return t;
  }();
  uint32_t c = 0xFFFFFFFFu;
  for (size_t i = 0; i < size; ++i) c = table[(c ^ uint8_t(data[i])) & 0xFF] ^ (c >> 8);
  return c ^ 0xFFFFFFFFu;
}

}  // namespace

bool is_png_data(const std::string& file_bytes) {
  return file_bytes.size() >= kSignatureBytes &&
         std::memcmp(file_bytes.data(), kSignature, kSignatureBytes) == 0;
}

std::string png_damage(const std::string& file_bytes) {
  if (!is_png_data(file_bytes)) return "not a PNG file (no PNG signature)";
  size_t at = kSignatureBytes;
  bool first = true;
  while (true) {
    if (file_bytes.size() - at < kChunkOverhead)
      return "truncated: the data ends before the IEND chunk";
    const uint32_t length = big_endian_value(file_bytes, at, 4);
    const std::string type = file_bytes.substr(at + 4, 4);
    if (length > kMaxChunkLength)
      return "corrupt: chunk length " + std::to_string(length) + " at byte " + std::to_string(at);
    if (first && type != "IHDR") return "corrupt: no IHDR chunk first";
    first = false;
    if (file_bytes.size() - at - kChunkOverhead < length)
      return "truncated: the data ends inside the " + type + " chunk at byte " + std::to_string(at);
    const uint32_t stored = big_endian_value(file_bytes, at + 8 + length, 4);
    if (crc32(file_bytes.data() + at + 4, 4 + size_t(length)) != stored)
      return "corrupt: CRC mismatch in the " + type + " chunk at byte " + std::to_string(at);
    if (type == "IEND") return "";
    at += kChunkOverhead + length;
  }
}

}  // namespace handscs
