// io/mp4_writer.h: the frames written read back through OpenCV's decoder (count, size, and close to
// the pictures within mp4v's loss), nothing is left beside the target, an unfinished video leaves an
// existing target as it was, and a target that cannot be written is named with the system's reason
// before any frame.
#include "catch_torch.h"

#include <filesystem>
#include <fstream>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "core/error.h"
#include "io/mp4_writer.h"
#include "test_support.h"

namespace fs = std::filesystem;

namespace {

// A smooth picture (a lit disc moving with k): mp4v keeps such frames close to their pixels.
cv::Mat frame(int k) {
  cv::Mat image(96, 128, CV_8UC3, cv::Scalar(40, 60, 80));
  cv::circle(image, cv::Point(30 + 8 * k, 48), 20, cv::Scalar(200, 180, 160), cv::FILLED);
  cv::GaussianBlur(image, image, cv::Size(9, 9), 3);
  return image;
}

int entries(const std::string& dir) {
  int n = 0;
  for ([[maybe_unused]] const auto& entry : fs::directory_iterator(dir)) ++n;
  return n;
}

}  // namespace

using handscs_test::error_of;

TEST_CASE("mp4 writer: frames read back, nothing left beside the video") {
  const std::string dir = handscs_test::scratch_path("handscs_test_mp4", "ok");
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string path = dir + "/v.mp4";
  {
    handscs::Mp4Writer video(path, 10);
    for (int k = 0; k < 6; ++k) video.write(frame(k));
    video.finish();
  }
  CHECK(entries(dir) == 1);
  cv::VideoCapture read(path);
  REQUIRE(read.isOpened());
  int frames = 0;
  cv::Mat got;
  while (read.read(got)) {
    REQUIRE(got.size() == frame(0).size());
    // Mean absolute error per channel value: mp4v at OpenCV's default quality stays within a few
    // levels on these smooth pictures; a wrong frame order or colour swap is off by tens.
    cv::Mat diff;
    cv::absdiff(got, frame(frames), diff);
    CHECK(cv::mean(diff.reshape(1))[0] < 6.0);
    ++frames;
  }
  CHECK(frames == 6);
}

TEST_CASE("mp4 writer: an unfinished video leaves the target as it was") {
  const std::string dir = handscs_test::scratch_path("handscs_test_mp4", "unfinished");
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string path = dir + "/v.mp4";
  std::ofstream(path) << "the earlier video";
  {
    handscs::Mp4Writer video(path, 30);
    video.write(frame(0));
    CHECK(error_of([&] { video.write(cv::Mat(10, 10, CV_8UC3)); }) ==
          path + ": all frames of a video need one image size (128x96 first, then 10x10)");
  }  // destroyed without finish(), as when rendering throws
  CHECK(entries(dir) == 1);
  std::ifstream in(path);
  std::string text;
  std::getline(in, text);
  CHECK(text == "the earlier video");
  handscs::Mp4Writer empty(path, 30);
  CHECK(error_of([&] { empty.finish(); }) == path + ": a video needs at least one frame");
}

TEST_CASE("mp4 writer: a target that cannot be written is named before any frame") {
  const std::string dir = handscs_test::scratch_path("handscs_test_mp4", "bad");
  fs::remove_all(dir);
  fs::create_directories(dir + "/a_folder.mp4");
  const std::string file = handscs_test::scratch_file("handscs_test_mp4", "bad/a_file", "x");
  CHECK(error_of([&] { handscs::Mp4Writer(dir + "/missing/v.mp4", 30); }) ==
        dir + "/missing/v.mp4: cannot write the video: " + dir + "/missing is not a folder");
  CHECK(error_of([&] { handscs::Mp4Writer(file + "/v.mp4", 30); }) ==
        file + "/v.mp4: cannot write the video: " + file + " is not a folder");
  CHECK(error_of([&] { handscs::Mp4Writer(dir + "/a_folder.mp4", 30); }) ==
        dir + "/a_folder.mp4: is a folder, not a video file");
  CHECK(error_of([&] { handscs::Mp4Writer(dir + "/v.mp4", 0); }) ==
        dir + "/v.mp4: video frame rate 0.000000 outside (0, 240]");
  // sysfs refuses new files even to root: the file system's own reason reaches the user
  // ("Permission denied", or "Read-only file system" where a container mounts /sys read-only).
  if (fs::is_directory("/sys/kernel")) {
    const std::string refused = error_of([&] { handscs::Mp4Writer("/sys/kernel/v.mp4", 30); });
    CHECK((refused == "/sys/kernel/v.mp4: cannot write the video (Permission denied)" ||
           refused == "/sys/kernel/v.mp4: cannot write the video (Read-only file system)"));
  }
}
