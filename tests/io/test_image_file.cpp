// io/image_file.h: decoding from the bytes of one checked read gives what cv::imread gives (EXIF
// orientation included), never blocks on a path swapped for a named pipe, and refuses a header
// stating more pixels than a camera may have before anything decodes it.
#include <catch2/catch.hpp>

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "core/atomic_file.h"
#include "core/error.h"
#include "io/image_file.h"
#include "path_swap.h"
#include "test_support.h"

namespace {

// `jpeg` with an Exif APP1 segment after its SOI whose one IFD entry sets Orientation (tag 0x0112,
// a SHORT) to `orientation`; 6 means "rotate 90 degrees clockwise to display".
std::string with_exif_orientation(const std::vector<uchar>& jpeg, int orientation) {
  const std::string tiff("MM\0*\0\0\0\x08", 8);  // big-endian TIFF header, first IFD at offset 8
  const std::string entry = std::string("\x01\x12\x00\x03\x00\x00\x00\x01\x00", 9) +
                            static_cast<char>(orientation) + std::string(2, '\0');
  const std::string ifd = std::string("\x00\x01", 2) + entry + std::string(4, '\0');
  const std::string payload = std::string("Exif\0\0", 6) + tiff + ifd;
  const size_t length = payload.size() + 2;
  const std::string segment = std::string("\xFF\xE1", 2) + static_cast<char>(length >> 8) +
                              static_cast<char>(length & 0xFF) + payload;
  return std::string(jpeg.begin(), jpeg.begin() + 2) + segment + std::string(jpeg.begin() + 2, jpeg.end());
}

bool same_pixels(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() && cv::norm(a, b, cv::NORM_INF) == 0;
}

}  // namespace

TEST_CASE("image_file: a JPEG's EXIF orientation is applied as cv::imread applies it") {
  cv::Mat image(2, 4, CV_8UC3);
  cv::randu(image, 0, 256);
  std::vector<uchar> jpeg;
  REQUIRE(cv::imencode(".jpg", image, jpeg));
  const std::string path = handscs_test::scratch_path("handscs_test_image_file", "rotated.jpg");
  handscs::write_file_atomic(path, with_exif_orientation(jpeg, 6));
  for (const int flags : {cv::IMREAD_COLOR, cv::IMREAD_GRAYSCALE, cv::IMREAD_UNCHANGED}) {
    INFO("flags " << flags);
    const cv::Mat decoded = handscs::decode_image_file(path, flags);
    CHECK(same_pixels(decoded, cv::imread(path, flags)));
    // Rotated to 4 rows x 2 columns unless the flags keep the file as stored.
    CHECK(decoded.rows == (flags == cv::IMREAD_UNCHANGED ? 2 : 4));
  }
}

TEST_CASE("image_file: a path swapped between a PNG and a named pipe never blocks the decode") {
  const auto dir = std::filesystem::temp_directory_path() / ("handscs_image_swap_" + std::to_string(getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const std::string path = (dir / "frame.png").string(), file = (dir / "file.png").string();
  cv::Mat image(3, 5, CV_8UC3);
  cv::randu(image, 0, 256);
  REQUIRE(cv::imwrite(file, image));
  const auto read = [&] {
    try {
      return same_pixels(handscs::decode_image_file(path, cv::IMREAD_COLOR), image)
                 ? handscs_test::SwapRead::file
                 : handscs_test::SwapRead::wrong;
    } catch (const handscs::Error& e) {
      return handscs_test::refusal_or_wrong(e.what(), path);
    }
  };
  // 1: wrong pixels or another error, 3: swap failed, 4: one kind only, -1: a decode blocked.
  CHECK(handscs_test::swapped_path_reads(path, file, read, 5000) == 0);
  std::filesystem::remove_all(dir);
}

TEST_CASE("image_file: undecodable bytes give an empty image; an oversized header is refused first") {
  const std::string text = handscs_test::scratch_file("handscs_test_image_file", "text.png", "not an image");
  CHECK(handscs::decode_image_file(text, cv::IMREAD_COLOR).empty());
  CHECK(handscs::decode_image_bytes("not an image", cv::IMREAD_COLOR, "x.png").empty());
  // A PNG signature and IHDR chunk stating 30000 x 30000 pixels, and nothing after it.
  const auto be32 = [](uint32_t v) {
    return std::string{static_cast<char>(v >> 24), static_cast<char>(v >> 16), static_cast<char>(v >> 8),
                       static_cast<char>(v)};
  };
  const std::string big = handscs_test::scratch_path("handscs_test_image_file", "big.png");
  handscs::write_file_atomic(big, std::string("\x89PNG\r\n\x1a\n", 8) + be32(13) + "IHDR" + be32(30000) +
                                      be32(30000) + std::string("\x08\x02\x00\x00\x00", 5));
  CHECK(handscs_test::error_of([&] { handscs::decode_image_file(big, cv::IMREAD_COLOR); }) ==
        big + ": its header says 30000 x 30000 pixels (900 megapixels), above the 100-megapixel "
              "limit of a camera");
  const std::string missing = handscs_test::scratch_path("handscs_test_image_file", "missing.png");
  std::filesystem::remove(missing);
  CHECK(handscs_test::error_of([&] { handscs::decode_image_file(missing, cv::IMREAD_COLOR); })
            .rfind(missing + ": ", 0) == 0);
}
