// core/png_damage.h against PNGs OpenCV encodes: a whole file passes; cut anywhere (inside a chunk,
// at a chunk boundary before IEND) it is named truncated; a flipped byte in any chunk is a CRC
// mismatch naming that chunk; a file that is not a PNG or starts with another chunk is named.
#include "catch_torch.h"

#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "core/png_damage.h"

namespace {

std::string encoded_png() {
  cv::Mat image(40, 56, CV_8UC3);
  cv::randu(image, 0, 256);
  std::vector<uchar> bytes;
  REQUIRE(cv::imencode(".png", image, bytes));
  return std::string(bytes.begin(), bytes.end());
}

// Byte offsets of each chunk (its length field) and its type, read independently of the checker.
std::vector<std::pair<size_t, std::string>> chunks(const std::string& png) {
  std::vector<std::pair<size_t, std::string>> out;
  for (size_t at = 8; at + 12 <= png.size();) {
    const uint32_t length = (uint32_t(uint8_t(png[at])) << 24) | (uint32_t(uint8_t(png[at + 1])) << 16) |
                            (uint32_t(uint8_t(png[at + 2])) << 8) | uint32_t(uint8_t(png[at + 3]));
    out.emplace_back(at, png.substr(at + 4, 4));
    at += 12 + length;
  }
  return out;
}

}  // namespace

TEST_CASE("png damage: whole, truncated and corrupted files") {
  const std::string png = encoded_png();
  REQUIRE(handscs::is_png_data(png));
  CHECK(handscs::png_damage(png).empty());
  const auto parts = chunks(png);
  REQUIRE(parts.front().second == "IHDR");
  REQUIRE(parts.back().second == "IEND");
  size_t idat = 0;
  for (const auto& [at, type] : parts)
    if (type == "IDAT" && idat == 0) idat = at;
  REQUIRE(idat > 0);

  // Cut inside the first IDAT, and cut exactly before IEND.
  CHECK(handscs::png_damage(png.substr(0, idat + 20)) ==
        "truncated: the data ends inside the IDAT chunk at byte " + std::to_string(idat));
  CHECK(handscs::png_damage(png.substr(0, parts.back().first)) ==
        "truncated: the data ends before the IEND chunk");
  CHECK(handscs::png_damage(png.substr(0, 8)) == "truncated: the data ends before the IEND chunk");

  // One byte flipped in each chunk's data or type: that chunk's CRC no longer matches.
  for (const auto& [at, type] : parts) {
    std::string flipped = png;
    flipped[at + 4 + (type == "IEND" ? 0 : 4)] ^= 0x10;  // IEND has no data: flip its type
    const std::string named = type == "IEND" ? std::string(flipped.substr(at + 4, 4)) : type;
    INFO(type);
    CHECK(handscs::png_damage(flipped) == "corrupt: CRC mismatch in the " + named + " chunk at byte " +
                                               std::to_string(at));
  }

  CHECK_FALSE(handscs::is_png_data("GIF89a"));
  CHECK(handscs::png_damage("GIF89a") == "not a PNG file (no PNG signature)");
  // The first chunk must be IHDR: the file from its second chunk on, behind a signature.
  const std::string headless = png.substr(0, 8) + png.substr(parts[1].first);
  CHECK(handscs::png_damage(headless) == "corrupt: no IHDR chunk first");
}
