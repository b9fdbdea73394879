// Walks the Huffman-coded image data of a sequential or progressive JPEG (SOF0, SOF1, SOF2; the
// InterHand2.6M images are progressive) code by code, without the inverse DCT, for the one class of
// damage libjpeg lets through (core/jpeg_damage.h runs this on files libjpeg decodes without a
// warning): coded data that holds an impossible value, a coefficient run past coefficient 63 or
// past the band's end, a DC difference of a category above the sample precision + 3, a bit pattern
// no Huffman code holds, from which libjpeg's decoder recovers within the scan (it indexes a
// padded zigzag table, takes the category as read, and its fast path decodes an unknown code as
// 0, all without a warning), so that the file decodes without a grey tail but with blocks changed
// (handscs-bench-jpeg_damage: 2.9% of single-bit flips in the coded data). The walk also names,
// where it has to stop anyway, damage libjpeg reports first (the data ending before the last block,
// bytes left over, malformed tables). Lossless and arithmetic-coded files are not walked.
#pragma once

#include <string>

namespace handscs {

// "" when every scan decodes to exactly the blocks the frame header asks for (or the file is not
// a Huffman-coded sequential or progressive JPEG); otherwise what is wrong, e.g. "corrupt image
// data: a coefficient run past 63 at block 1203 of 2688 (byte 18233)". Safe on any bytes.
std::string jpeg_entropy_problem(const std::string& file_bytes);

}  // namespace handscs
