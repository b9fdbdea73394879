// JPEG marker codes (ITU T.81 table B.1), shared by the structure check and the coded-data walk.
#pragma once

#include <cstdint>

namespace handscs::jpeg {

constexpr uint8_t kSof0 = 0xC0, kSof1 = 0xC1, kSof2 = 0xC2, kDht = 0xC4, kDac = 0xCC;
constexpr uint8_t kRst0 = 0xD0, kRst7 = 0xD7, kSoi = 0xD8, kEoi = 0xD9, kSos = 0xDA, kDri = 0xDD;
constexpr uint8_t kTem = 0x01;

// A frame header SOF0-SOF15 (C0-CF without DHT C4, the reserved JPG C8 and DAC CC).
constexpr bool is_frame_header(uint8_t m) { return m >= 0xC0 && m <= 0xCF && m != kDht && m != 0xC8 && m != kDac; }

}  // namespace handscs::jpeg
