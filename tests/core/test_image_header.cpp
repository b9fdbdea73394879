// Image header sizes (core/image_header.h): read from hand-built PNG and JPEG headers and from the
// InterHand2.6M samples (their sizes as `file` reads them), and a header
// claiming more pixels than a camera may have is refused before any decode.
#include <catch2/catch.hpp>

#include <string>
#include <tuple>
#include <vector>

#include "core/atomic_file.h"
#include "core/image_header.h"
#include "test_support.h"

namespace {

std::string be(int64_t v, int bytes) {
  std::string out;
  for (int k = bytes - 1; k >= 0; --k) out += static_cast<char>((v >> (8 * k)) & 0xFF);
  return out;
}

std::string png_header(int64_t width, int64_t height) {
  return std::string("\x89PNG\r\n\x1a\n", 8) + be(13, 4) + "IHDR" + be(width, 4) + be(height, 4) +
         std::string("\x08\x02\x00\x00\x00", 5);
}

// SOI, an APP0 segment, a DHT (C4, which is no frame header), then SOF2 with the size.
std::string jpeg_header(int64_t width, int64_t height) {
  return std::string("\xFF\xD8", 2) + std::string("\xFF\xE0", 2) + be(16, 2) + std::string(14, 'j') +
         std::string("\xFF\xC4", 2) + be(5, 2) + std::string(3, '\0') + std::string("\xFF\xC2", 2) +
         be(17, 2) + std::string("\x08", 1) + be(height, 2) + be(width, 2) + std::string(12, '\0');
}

}  // namespace

TEST_CASE("image header: PNG and JPEG sizes are read before decoding, oversized ones refused") {
  auto size = handscs::image_header_size(png_header(640, 480));
  CHECK(size.known);
  CHECK(size.width == 640);
  CHECK(size.height == 480);
  size = handscs::image_header_size(jpeg_header(512, 334));
  CHECK(size.known);
  CHECK(size.width == 512);
  CHECK(size.height == 334);
  // Width x height as `file` prints them for the samples (one landscape, three portrait).
  const std::vector<std::tuple<std::string, int64_t, int64_t>> samples = {
      {"image2017.jpg", 512, 334}, {"image29590.jpg", 334, 512},
      {"image44669.jpg", 334, 512}, {"image69148.jpg", 334, 512}};
  for (const auto& [name, width, height] : samples) {
    INFO(name);
    const auto real = handscs::image_header_size(
        handscs::read_file(std::string(HANDSCS_SHARED_DIR) + "/testdata/interhand2.6m/" + name));
    CHECK(real.known);
    CHECK(real.width == width);
    CHECK(real.height == height);
  }
  CHECK_FALSE(handscs::image_header_size("BM not an image").known);
  CHECK_FALSE(handscs::image_header_size(png_header(10, 10).substr(0, 20)).known);
  CHECK_FALSE(handscs::image_header_size(jpeg_header(10, 10).substr(0, 30)).known);

  CHECK(handscs_test::error_of([] {
          handscs::refuse_oversized_image_header(png_header(30000, 30000), "big.png");
        }) == "big.png: its header says 30000 x 30000 pixels (900 megapixels), above the "
              "100-megapixel limit of a camera");
  CHECK(handscs_test::error_of([] {
          handscs::refuse_oversized_image_header(jpeg_header(65535, 65535), "big.jpg");
        }) == "big.jpg: its header says 65535 x 65535 pixels (4295 megapixels), above the "
              "100-megapixel limit of a camera");
  CHECK(handscs_test::error_of([] {
          handscs::refuse_oversized_image_header(png_header(10000, 10000), "ok.png");
        }) == "(no error)");
}
