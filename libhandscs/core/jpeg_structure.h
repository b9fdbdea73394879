// A byte-level check of a JPEG file's marker structure, run before decoding: libjpeg decodes a
// truncated or partly overwritten file into an image with a grey tail and only prints a warning
// without a path, so damage has to be found before the decoder sees the bytes.
// What this finds is cached per image (data/scan_cache.h): a change to what it reports for a file
// must bump kImageChecksVersion in data/image_checks.h, or cached results of the old checks stay.
#pragma once

#include <string>

#include "core/jpeg_damage.h"  // has_jpeg_extension

namespace handscs {

// "" when the bytes are a structurally whole JPEG: SOI, well-formed segments, entropy-coded data
// holding only stuffed bytes and restart markers in sequence, and an EOI marker, and (for
// sequential Huffman JPEGs) coded data that decodes to exactly the frame's blocks
// (jpeg_entropy.h). Otherwise what is wrong, e.g. "truncated: the image data ends without an
// end-of-image marker", "not a JPEG file (PNG data)". A flip that changes a coefficient's value
// bits, or that the Huffman code recovers from within the scan, is not detected (it changes a few
// 8x8 blocks, not the rest of the image).
std::string jpeg_structure_problem(const std::string& file_bytes);

// An image file's bytes, for a decoder; `jpeg_problem` receives jpeg_structure_problem's answer for
// a .jpg/.jpeg ("" otherwise). Throws Error naming the file when it cannot be read or is over 2 GB
// (no frame is; OpenCV's decode buffer is indexed by int).
std::string read_image_file(const std::string& path, std::string& jpeg_problem);

}  // namespace handscs
