// io/png.h: what is written reads back pixel for pixel through OpenCV's decoder (grey and colour),
// the folder is created, and a path that cannot be written is an error naming it.
#include "catch_torch.h"

#include <filesystem>
#include <opencv2/imgcodecs.hpp>

#include "core/error.h"
#include "io/png.h"
#include "test_support.h"

namespace fs = std::filesystem;

TEST_CASE("png: grey and colour images read back exactly, folders are created") {
  const std::string dir = handscs_test::scratch_path("handscs_test_png", "nested/deeper");
  fs::remove_all(fs::path(dir).parent_path());
  cv::Mat grey(7, 5, CV_8UC1), colour(4, 9, CV_8UC3);
  cv::randu(grey, 0, 256);
  cv::randu(colour, 0, 256);
  handscs::write_png(dir + "/grey.png", grey);
  handscs::write_png(dir + "/colour.png", colour);
  const cv::Mat grey_back = cv::imread(dir + "/grey.png", cv::IMREAD_UNCHANGED);
  const cv::Mat colour_back = cv::imread(dir + "/colour.png", cv::IMREAD_UNCHANGED);
  REQUIRE(grey_back.type() == CV_8UC1);
  REQUIRE(colour_back.type() == CV_8UC3);
  CHECK(cv::countNonZero(grey_back != grey) == 0);
  cv::Mat diff;
  cv::absdiff(colour_back, colour, diff);
  CHECK(cv::countNonZero(diff.reshape(1)) == 0);
  // No temporary files are left beside them.
  int files = 0;
  for ([[maybe_unused]] const auto& entry : fs::directory_iterator(dir)) ++files;
  CHECK(files == 2);
}

TEST_CASE("png: a path that cannot be written names it") {
  const std::string file = handscs_test::scratch_file("handscs_test_png", "a_file", "x");
  const std::string path = file + "/under_a_file.png";
  try {
    handscs::write_png(path, cv::Mat(2, 2, CV_8UC1, cv::Scalar(0)));
    FAIL("no error");
  } catch (const handscs::Error& e) {
    CHECK(std::string(e.what()).find(file) != std::string::npos);
  }
}

TEST_CASE("png: float tensors are written as 8-bit RGB or grey, clamped and rounded") {
  const std::string dir = handscs_test::scratch_path("handscs_test_png", "tensors");
  auto rgb = torch::zeros({2, 3, 3});
  rgb[0][0][0] = 1.0;   // pure red
  rgb[0][1][1] = 0.5;   // 127.5 rounds to 128
  rgb[1][2][2] = 2.0;   // clamped to 255
  rgb[1][0][0] = -1.0;  // clamped to 0
  handscs::write_png(dir + "/rgb.png", rgb);
  const cv::Mat back = cv::imread(dir + "/rgb.png", cv::IMREAD_UNCHANGED);  // BGR
  REQUIRE(back.type() == CV_8UC3);
  CHECK(back.at<cv::Vec3b>(0, 0) == cv::Vec3b(0, 0, 255));
  CHECK(back.at<cv::Vec3b>(0, 1) == cv::Vec3b(0, 128, 0));
  CHECK(back.at<cv::Vec3b>(1, 2) == cv::Vec3b(255, 0, 0));
  CHECK(back.at<cv::Vec3b>(1, 0) == cv::Vec3b(0, 0, 0));
  handscs::write_png(dir + "/grey.png", torch::full({4, 2}, 0.25));
  const cv::Mat grey = cv::imread(dir + "/grey.png", cv::IMREAD_UNCHANGED);
  REQUIRE(grey.type() == CV_8UC1);
  CHECK(grey.at<uint8_t>(3, 1) == 64);  // 63.75 rounds to 64
  CHECK_THROWS_AS(handscs::write_png(dir + "/bad.png", torch::zeros({2, 2, 4})), handscs::Error);
}
