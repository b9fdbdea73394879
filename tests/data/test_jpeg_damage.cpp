// The JPEG damage check (libjpeg's own errors and warnings) against files written by libjpeg
// (through OpenCV): whole baseline, progressive and restart-interval files pass; every truncation,
// a PNG or BMP renamed, an invalid marker or a restart marker out of order is named; a damaged JPEG
// in a capture is skipped with its path and reason; every cut closed with an end-of-image marker
// (libjpeg's grey tail) is found; flips that put the Huffman decoder out of step are named; a bad
// progression is refused, harmless metadata and a byte left over after a scan (the known gap) pass;
// and the check's 1/8 decode is OpenCV's.
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "core/atomic_file.h"
#include "core/jpeg_damage.h"
#include "data/capture.h"
#include "data/image_checks.h"
#include "data_test_helpers.h"
#include "synth_fixture.h"

// Catch last: LibTorch pulls in glog, whose CHECK macro would otherwise replace Catch's.
#include <catch2/catch.hpp>

using namespace handscs;

namespace {

// A textured 96x64 colour image: enough entropy-coded data for 0xFF bytes and many blocks.
cv::Mat test_image() {
  cv::Mat image(64, 96, CV_8UC3);
  cv::randu(image, cv::Scalar(0, 0, 0), cv::Scalar(255, 255, 255));
  cv::GaussianBlur(image, image, cv::Size(3, 3), 0);
  return image;
}

std::string encode(const std::string& ext, const std::vector<int>& params = {}) {
  std::vector<uint8_t> bytes;
  REQUIRE(cv::imencode(ext, test_image(), bytes, params));
  return std::string(bytes.begin(), bytes.end());
}

// Offset of the first entropy-coded byte (after the SOS segment).
size_t scan_start(const std::string& jpeg) {
  const size_t sos = jpeg.find("\xFF\xDA");
  REQUIRE(sos != std::string::npos);
  const size_t length = (static_cast<uint8_t>(jpeg[sos + 2]) << 8) | static_cast<uint8_t>(jpeg[sos + 3]);
  return sos + 2 + length;
}

}  // namespace

TEST_CASE("jpeg damage: whole files written by libjpeg pass") {
  CHECK(jpeg_damage(encode(".jpg")).empty());
  CHECK(jpeg_damage(encode(".jpg", {cv::IMWRITE_JPEG_QUALITY, 100})).empty());
  CHECK(jpeg_damage(encode(".jpg", {cv::IMWRITE_JPEG_PROGRESSIVE, 1})).empty());
  CHECK(jpeg_damage(encode(".jpg", {cv::IMWRITE_JPEG_RST_INTERVAL, 2})).empty());
  // Trailing bytes after the end-of-image marker are allowed (cameras append data there).
  CHECK(jpeg_damage(encode(".jpg") + std::string(16, '\0')).empty());
  // The InterHand2.6M samples.
  for (const auto& entry : std::filesystem::directory_iterator(data_test::samples_dir()))
    if (has_jpeg_extension(entry.path().string())) {
      INFO(entry.path());
      CHECK(jpeg_damage(read_file(entry.path().string())).empty());
    }
}

TEST_CASE("jpeg damage: every truncation is found") {
  for (const auto& jpeg : {encode(".jpg"), encode(".jpg", {cv::IMWRITE_JPEG_PROGRESSIVE, 1})}) {
    // Brute force over every length short of the final EOI marker's two bytes.
    for (size_t length = 0; length + 2 <= jpeg.size() - 1; ++length) {
      const std::string problem = jpeg_damage(jpeg.substr(0, length));
      INFO("length " << length << " of " << jpeg.size());
      CHECK_FALSE(problem.empty());
    }
    CHECK(jpeg_damage(jpeg.substr(0, jpeg.size() / 2)) ==
          "truncated: the image data ends without an end-of-image marker");
  }
}

TEST_CASE("jpeg damage: other formats, invalid markers and restart order are named") {
  CHECK(jpeg_damage(encode(".png")) == "not a JPEG file (PNG data)");
  CHECK(jpeg_damage(encode(".bmp")) == "not a JPEG file (BMP data)");
  CHECK(jpeg_damage("") == "empty file");
  CHECK(jpeg_damage("not a jpeg") == "not a JPEG file (no start-of-image marker)");

  // A 0xFF byte followed by a code that is no marker, inside the image data.
  std::string bad = encode(".jpg");
  const size_t at = scan_start(bad) + 10;
  bad[at] = '\xFF';
  bad[at + 1] = '\x02';
  CHECK(jpeg_damage(bad) == "corrupt: unsupported marker type 0x02 at byte " + std::to_string(at));

  // Restart markers must count RST0, RST1, ...: swap the first one for RST5.
  std::string restarts = encode(".jpg", {cv::IMWRITE_JPEG_RST_INTERVAL, 1});
  const size_t rst = restarts.find("\xFF\xD0", scan_start(restarts));
  REQUIRE(rst != std::string::npos);
  restarts[rst + 1] = '\xD5';
  CHECK(jpeg_damage(restarts) == "corrupt image data: found marker 0xd5 instead of RST0 at byte " + std::to_string(rst));
}

TEST_CASE("jpeg damage: a truncated JPEG in a capture is skipped with its reason") {
  const std::string root = data_test::copy_of_tiny("damaged_jpeg");
  const auto& scene = data_test::tiny_capture().scene;
  const std::string path = root + "/images/test/Capture0/0000_synth_rom/cam400004/image" +
                           std::to_string(scene.frames[5].frame_idx) + ".jpg";
  const std::string whole = read_file(path);
  data_test::write_text(path, whole.substr(0, whole.size() * 3 / 4));
  // OpenCV decodes it (with a grey tail): the damage check is what catches it.
  CHECK_FALSE(cv::imread(path).empty());
  CHECK(scan_image(path).damage == "truncated: the image data ends without an end-of-image marker");
  Capture capture = Capture::open(data_test::tiny_config(root));
  REQUIRE(capture.skipped().size() == 1);
  CHECK(capture.skipped()[0].path == path);
  CHECK(capture.skipped()[0].reason == "damaged JPEG");
  CHECK(capture.frames().size() == 47);
}

TEST_CASE("jpeg damage: image data cut anywhere and closed with an end-of-image marker is found") {
  // The grey-tail case: libjpeg decodes such a file, filling the missing blocks with grey, and
  // through OpenCV only prints "Corrupt JPEG data: premature end of data segment" without a path.
  const cv::Mat grey = [] {
    cv::Mat g;
    cv::cvtColor(test_image(), g, cv::COLOR_BGR2GRAY);
    return g;
  }();
  std::vector<uint8_t> grey_bytes;
  REQUIRE(cv::imencode(".jpg", grey, grey_bytes));
  const std::vector<std::string> files = {encode(".jpg"), encode(".jpg", {cv::IMWRITE_JPEG_QUALITY, 100}),
                                          encode(".jpg", {cv::IMWRITE_JPEG_RST_INTERVAL, 2}),
                                          encode(".jpg", {cv::IMWRITE_JPEG_PROGRESSIVE, 1}),
                                          std::string(grey_bytes.begin(), grey_bytes.end()),
                                          // an InterHand2.6M image (progressive, 10 scans)
                                          read_file(data_test::samples_dir() + "/image69148.jpg")};
  for (const auto& jpeg : files) {
    REQUIRE(jpeg_damage(jpeg).empty());
    const size_t start = scan_start(jpeg);
    const size_t end = jpeg.rfind("\xFF\xD9");
    size_t found = 0, cuts = 0;
    for (size_t cut = start; cut < end; ++cut) {
      // Keep the structure whole: never cut after a 0xFF (a stuffed byte or a marker follows).
      // Cuts inside a later scan's header or a table between scans are the structure check's.
      if (static_cast<uint8_t>(jpeg[cut - 1]) == 0xFF) continue;
      // A progressive file cut just before a marker is a whole file with fewer scans (legal).
      if (static_cast<uint8_t>(jpeg[cut]) == 0xFF && static_cast<uint8_t>(jpeg[cut + 1]) != 0x00) continue;
      if (!jpeg_damage(jpeg.substr(0, cut) + "\xFF\xD9").empty()) ++found;
      ++cuts;
    }
    INFO("cuts " << cuts);
    CHECK(found == cuts);
  }
  const std::string jpeg = encode(".jpg");
  const std::string half = jpeg.substr(0, (scan_start(jpeg) + jpeg.size()) / 2) + "\xFF\xD9";
  std::vector<uint8_t> half_bytes(half.begin(), half.end());
  CHECK_FALSE(cv::imdecode(half_bytes, cv::IMREAD_COLOR).empty());  // libjpeg takes it
  const std::string problem = jpeg_damage(half);
  INFO(problem);
  CHECK(problem.rfind("truncated image data: premature end of data segment at byte ", 0) == 0);
}

TEST_CASE("jpeg damage: flipped bits that put the Huffman decoder out of step are named") {
  const std::string jpeg = encode(".jpg");
  const size_t start = scan_start(jpeg);
  int named = 0;
  for (size_t at = start; at < start + 64; ++at)
    for (int bit = 0; bit < 8; ++bit) {
      std::string flipped = jpeg;
      flipped[at] = static_cast<char>(static_cast<uint8_t>(flipped[at]) ^ (1 << bit));
      // Only flips that keep the marker structure (no new or broken 0xFF) test the decoder.
      if (static_cast<uint8_t>(flipped[at]) == 0xFF || static_cast<uint8_t>(jpeg[at]) == 0xFF ||
          static_cast<uint8_t>(jpeg[at - 1]) == 0xFF)
        continue;
      const std::string problem = jpeg_damage(flipped);
      if (problem.empty()) continue;
      ++named;
      INFO(problem);
      CHECK((problem.rfind("corrupt image data: ", 0) == 0 || problem.rfind("truncated image data: ", 0) == 0));
      if (named == 1) {  // libjpeg decodes such a file regardless (printing a warning)
        std::vector<uint8_t> bytes(flipped.begin(), flipped.end());
        CHECK_FALSE(cv::imdecode(bytes, cv::IMREAD_COLOR).empty());
      }
    }
  CHECK(named > 0);
}

TEST_CASE("jpeg damage: a bad progression is refused; harmless metadata and the known gap pass") {
  const std::string whole = read_file(data_test::samples_dir() + "/image69148.jpg");
  // Known gap: a flip in the first (DC) scan that ends it a byte early passes, as libjpeg's bit
  // buffer drops the byte left over without a warning (OpenCV decodes the file).
  std::string early = whole;
  early[388] = static_cast<char>(static_cast<uint8_t>(early[388]) ^ 1);
  CHECK(jpeg_damage(early).empty());
  // A flip in a later scan's header: libjpeg refuses the progression.
  std::string header = whole;
  header[6508] = static_cast<char>(static_cast<uint8_t>(header[6508]) ^ (1 << 5));
  CHECK(jpeg_damage(header) == "corrupt: invalid progressive parameters Ss=1 Se=63 Ah=3 Al=0 at byte 6509");
  // Metadata libjpeg warns about without changing a pixel is no damage: a JFIF revision 2.01.
  std::string jfif = encode(".jpg");
  REQUIRE(jfif.compare(6, 5, std::string("JFIF\0", 5)) == 0);
  jfif[11] = 2;
  CHECK(jpeg_damage(jfif).empty());
}

TEST_CASE("jpeg damage: the check's 1/8 decode is OpenCV's IMREAD_REDUCED_COLOR_8") {
  cv::Mat grey;
  cv::cvtColor(test_image(), grey, cv::COLOR_BGR2GRAY);
  std::vector<uint8_t> grey_bytes;
  REQUIRE(cv::imencode(".jpg", grey, grey_bytes));
  cv::Mat odd;  // partial MCUs at the right and bottom edges
  cv::resize(test_image(), odd, cv::Size(97, 61));
  std::vector<uint8_t> odd_bytes;
  REQUIRE(cv::imencode(".jpg", odd, odd_bytes, {cv::IMWRITE_JPEG_PROGRESSIVE, 1}));
  std::vector<std::string> files = {encode(".jpg"), encode(".jpg", {cv::IMWRITE_JPEG_RST_INTERVAL, 2}),
                                    encode(".jpg", {cv::IMWRITE_JPEG_PROGRESSIVE, 1}),
                                    std::string(grey_bytes.begin(), grey_bytes.end()),
                                    std::string(odd_bytes.begin(), odd_bytes.end())};
  for (const char* name : {"image2017.jpg", "image29590.jpg", "image44669.jpg", "image69148.jpg"})
    files.push_back(read_file(data_test::samples_dir() + "/" + name));
  for (const auto& jpeg : files) {
    JpegThumbnail thumbnail;
    REQUIRE(jpeg_damage(jpeg, &thumbnail).empty());
    const std::vector<uint8_t> bytes(jpeg.begin(), jpeg.end());
    const cv::Mat expected = cv::imdecode(bytes, cv::IMREAD_REDUCED_COLOR_8);
    REQUIRE(thumbnail.width == expected.cols);
    REQUIRE(thumbnail.height == expected.rows);
    const cv::Mat got(thumbnail.height, thumbnail.width, CV_8UC3, thumbnail.bgr.data());
    CHECK(cv::norm(got, expected, cv::NORM_INF) == 0);
  }
  // No decode is handed out for a damaged file, nor for one with Exif data (OpenCV would apply its
  // orientation): an APP1 "Exif" segment after the start-of-image marker.
  JpegThumbnail thumbnail;
  const std::string jpeg = encode(".jpg");
  CHECK_FALSE(jpeg_damage(jpeg.substr(0, jpeg.size() / 2), &thumbnail).empty());
  CHECK(thumbnail.bgr.empty());
  const std::string exif = jpeg.substr(0, 2) + std::string("\xFF\xE1\x00\x08" "Exif\0\0", 10) + jpeg.substr(2);
  CHECK(jpeg_damage(exif, &thumbnail).empty());
  CHECK(thumbnail.bgr.empty());
}
