// Walks the Huffman-coded image data of a sequential or progressive JPEG (SOF0, SOF1, SOF2; the
// InterHand2.6M images are progressive) code by code, without the inverse DCT: a flipped bit inside the entropy-coded data keeps the marker
// structure (jpeg_structure.h) intact, but it puts the Huffman decoder out of step, so that it
// meets a code no table holds, a run past coefficient 63, a restart marker before its interval
// is decoded, or the end of the data before the last block (libjpeg then fills the rest of the
// image with grey and only prints a warning without a path). Lossless and arithmetic-coded
// files are not walked.
// What this finds is cached per image (data/scan_cache.h): a change to what it reports for a file
// must bump kImageChecksVersion in data/image_checks.h, or cached results of the old checks stay.
#pragma once

#include <string>

namespace handscs {

// "" when every scan decodes to exactly the blocks the frame header asks for (or the file is not
// a Huffman-coded sequential or progressive JPEG); otherwise what is wrong, e.g. "corrupt image data: no Huffman code
// matches at block 1203 of 2688 (byte 18233)". `file_bytes` must have passed
// jpeg_structure_problem's structural check.
std::string jpeg_entropy_problem(const std::string& file_bytes);

}  // namespace handscs
