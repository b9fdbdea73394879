#include "core/jpeg_structure.h"

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <limits>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/jpeg_damage.h"
#include "core/jpeg_entropy.h"
#include "core/jpeg_markers.h"

namespace handscs {
namespace {

using jpeg::kEoi;
using jpeg::kRst0;
using jpeg::kRst7;
using jpeg::kSoi;
using jpeg::kSos;
using jpeg::kTem;

std::string hex(uint8_t value) {
  char text[8];
  std::snprintf(text, sizeof text, "0x%02X", value);
  return text;
}

// Markers that may stand between or after the scans: tables (DHT C4, DAC CC, DQT DB), DRI DD,
// DNL DC, EXP DF, APPn E0-EF, COM FE, and the frame headers SOF0-SOF15 (C0-CF without C4, C8, CC).
bool is_segment_marker(uint8_t m) {
  return (m >= 0xC0 && m <= 0xCF && m != 0xC8) || m == 0xDB || m == 0xDC || m == 0xDD ||
         m == 0xDF || (m >= 0xE0 && m <= 0xEF) || m == 0xFE;
}

}  // namespace

std::string jpeg_structure_problem(const std::string& file_bytes) {
  const auto* bytes = reinterpret_cast<const uint8_t*>(file_bytes.data());
  const size_t n = file_bytes.size();
  if (n < 2 || bytes[0] != 0xFF || bytes[1] != kSoi) return jpeg_damage(file_bytes);  // names what it holds
  bool seen_frame = false, seen_scan = false;
  size_t pos = 2;
  while (true) {
    // A marker: 0xFF, optional 0xFF fill bytes, the code.
    if (pos >= n) return "truncated: the file ends before its end-of-image marker";
    if (bytes[pos] != 0xFF)
      return "corrupt: expected a marker at byte " + std::to_string(pos) + ", found " + hex(bytes[pos]);
    while (pos < n && bytes[pos] == 0xFF) ++pos;
    if (pos >= n) return "truncated: the file ends inside a marker";
    const uint8_t marker = bytes[pos++];
    if (marker == kEoi) {
      if (!seen_scan) return "corrupt: end-of-image marker before any image data";
      return jpeg_entropy_problem(file_bytes);  // the structure is whole: now the coded data
    }
    if (marker == kTem || (marker >= kRst0 && marker <= kRst7))
      return "corrupt: marker " + hex(marker) + " outside the image data at byte " + std::to_string(pos - 2);
    if (marker != kSos && !is_segment_marker(marker))
      return "corrupt: unknown marker " + hex(marker) + " at byte " + std::to_string(pos - 2);
    if (pos + 2 > n) return "truncated: the file ends inside a segment header";
    const size_t length = (static_cast<size_t>(bytes[pos]) << 8) | bytes[pos + 1];
    if (length < 2) return "corrupt: segment " + hex(marker) + " has length " + std::to_string(length);
    if (pos + length > n) return "truncated: segment " + hex(marker) + " extends past the end of the file";
    if (jpeg::is_frame_header(marker)) seen_frame = true;
    pos += length;
    if (marker != kSos) continue;
    if (!seen_frame) return "corrupt: image data before the frame header";
    seen_scan = true;
    // Entropy-coded data: 0xFF is followed by 0x00 (a stuffed byte) or a restart marker, which
    // must count RST0..RST7 in order; any other marker ends the scan.
    int expected_restart = 0;
    while (true) {
      pos = static_cast<size_t>(std::find(bytes + pos, bytes + n, uint8_t{0xFF}) - bytes);
      if (pos + 1 >= n) return "truncated: the image data ends without an end-of-image marker";
      const uint8_t next = bytes[pos + 1];
      if (next == 0x00) {
        pos += 2;
      } else if (next >= kRst0 && next <= kRst7) {
        if (next - kRst0 != expected_restart)
          return "corrupt: restart marker " + hex(next) + " out of sequence at byte " + std::to_string(pos);
        expected_restart = (expected_restart + 1) % 8;
        pos += 2;
      } else if (next == 0xFF) {
        ++pos;  // fill byte before a marker
      } else {
        break;  // a marker: back to the segment loop
      }
    }
  }
}

std::string read_image_file(const std::string& path, std::string& jpeg_problem) {
  std::string bytes = read_file(path);
  if (bytes.size() > static_cast<size_t>(std::numeric_limits<int>::max()))
    throw Error(path + ": larger than 2 GB; not an image file");
  jpeg_problem = has_jpeg_extension(path) ? jpeg_structure_problem(bytes) : "";
  return bytes;
}

}  // namespace handscs
