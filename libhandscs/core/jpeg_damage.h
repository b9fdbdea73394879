// Damage to a JPEG file: what libjpeg itself reports while decoding it at 1/8 scale (its errors,
// and the warnings it otherwise only prints without a path while filling what it could not decode
// with grey: a cut file, coded data that ends before the last block, a bad Huffman code, restart
// markers out of order, bytes left over after a scan).
// What this finds is cached per image (data/scan_cache.h): a change to what it reports for a file
// must bump kImageChecksVersion in data/image_checks.h, or cached results of the old checks stay.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace handscs {

// The 1/8-scale decode the check makes, as 8-bit BGR rows: what cv::imdecode gives with
// cv::IMREAD_REDUCED_COLOR_8 for a file without Exif data and with 1 or 3 components.
struct JpegThumbnail {
  int width = 0, height = 0;
  std::vector<uint8_t> bgr;  // [height, width, 3]
};

// "" when libjpeg decodes `file_bytes` with neither error nor warning; otherwise what is wrong,
// e.g. "truncated: the image data ends without an end-of-image marker", "truncated image data:
// premature end of data segment at byte 18233", "corrupt image data: bad Huffman code at byte 903",
// "corrupt: unsupported marker type 0x02 at byte 623", "not a JPEG file (PNG data)". The byte is
// where libjpeg's reader stood (the marker's offset when it has just read one). The entropy-coded
// data is parsed in full at any scale (libjpeg reads and drops the codes of coefficients a scaled
// decode does not need), so the 1/8 scale costs no detection. Not detected: damage to the coded data
// that libjpeg's decoder recovers from in silence (a flip that changes only a coefficient's value
// bits, a code its tables do not hold, a coefficient run past the block).
// `thumbnail` (optional) receives the decode of an undamaged file when it is a colour or grey JPEG
// without an Exif segment (OpenCV would apply its orientation); otherwise it is left empty.
std::string jpeg_damage(const std::string& file_bytes, JpegThumbnail* thumbnail = nullptr);

// True for the .jpg / .jpeg extensions (any case): the files jpeg_damage applies to.
bool has_jpeg_extension(const std::string& path);

// An image file's bytes, for a decoder; `jpeg_problem` receives jpeg_damage's answer for a
// .jpg/.jpeg ("" otherwise), `thumbnail` (optional) its 1/8-scale decode. Throws Error naming the
// file as read_image_bytes does (core/image_header.h): not readable, too large, or a header stating
// more pixels than a camera may have.
std::string read_image_file(const std::string& path, std::string& jpeg_problem, JpegThumbnail* thumbnail = nullptr);

}  // namespace handscs
