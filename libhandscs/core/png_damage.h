// Damage to a PNG file found by walking its chunks (length, type, data, CRC-32) from the signature
// to IEND, before any decoder sees it: libpng reports a cut or corrupted file only by printing
// "libpng error: ..." on its own, without the path, after OpenCV has started decoding. Not
// detected: damage inside the compressed image data that keeps every chunk's CRC (a file written
// that way by a faulty encoder).
#pragma once

#include <string>

namespace handscs {

// True when `file_bytes` start with the 8-byte PNG signature.
bool is_png_data(const std::string& file_bytes);

// "" when the chunks are whole and end with IEND; otherwise what is wrong, e.g. "truncated: the
// data ends inside the IDAT chunk at byte 1043", "truncated: the data ends before the IEND chunk",
// "corrupt: CRC mismatch in the IDAT chunk at byte 57", "corrupt: no IHDR chunk first".
std::string png_damage(const std::string& file_bytes);

}  // namespace handscs
