// POSES files: each bad file is an error naming the file (and the key where there is one), never a
// bare nlohmann exception or an unbounded allocation.
#include "catch_torch.h"

#include <filesystem>
#include <fstream>

#include "core/error.h"
#include "train/tiny_capture.h"
#include "infer/pose_source.h"

namespace {
std::string error_of(const std::string& path, const std::string& text) {
  std::ofstream(path) << text;
  try {
    handscs::read_pose_source(path);
  } catch (const handscs::Error& e) {
    return e.what();
  }
  return "";
}
}  // namespace

TEST_CASE("pose source: wrong types, overflowing numbers and huge interpolations name the file") {
  const auto dir = handscs_test::fresh_dir("pose_source");
  std::filesystem::create_directories(dir);
  const auto path = dir + "/poses.json";
  const std::string zeros45 = "0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0";
  const std::string pose = "[0,0,0," + zeros45 + "]";
  {
    std::ofstream(path) << "{\"poses\": [{\"pose\": " + pose + "}]}";
  }
  CHECK(handscs::read_pose_source(path).size() == 1);
  CHECK(error_of(path, "{\"poses\": [{\"pose\": " + pose.substr(0, pose.size() - 1) + ",1e999]}]}")
            .rfind(path + ": a number is out of range of a double", 0) == 0);
  const auto steps_type = error_of(path, "{\"interpolate\": {\"from\": {\"pose\": " + pose +
                                             "}, \"to\": {\"pose\": " + pose + "}, \"steps\": \"ten\"}}");
  INFO(steps_type);
  CHECK(steps_type == path + ": interpolate.steps: expected an integer, got string");
  CHECK(error_of(path, "{\"poses\": [{\"pose\": " + pose + ", \"name\": 5}]}") ==
        path + ": poses[0].name: expected a string, got number");
  CHECK(error_of(path, "{\"capture\": {}, \"frames\": 3}") == path + ": frames: expected a string, got number");
  CHECK(error_of(path, "{\"capture\": {}, \"max_frames\": \"all\"}") ==
        path + ": max_frames: expected an integer, got string");
  CHECK(error_of(path, "{\"interpolate\": {\"from\": {\"pose\": " + pose + "}, \"to\": {\"pose\": " + pose +
                           "}, \"steps\": 100000000}}") ==
        path + ": interpolate.steps: between 2 and 1000000, got 100000000");
  CHECK(error_of(dir, "") == dir + ": is a folder, not a JSON file");
  // Two motion sources in one file: neither is silently ignored.
  CHECK(error_of(path, "{\"poses\": [{\"pose\": " + pose + "}], \"interpolate\": {}}") ==
        path + ": holds both \"poses\" and \"interpolate\"; give one motion source per file");
  CHECK(error_of(path, "{\"interpolate\": {}, \"capture\": {}}") ==
        path + ": holds both \"interpolate\" and \"capture\"; give one motion source per file");
}

TEST_CASE("pose source: poses beyond the MANO annotations' plausibility bounds are errors") {
  const auto dir = handscs_test::fresh_dir("pose_bounds");
  std::filesystem::create_directories(dir);
  const auto path = dir + "/poses.json";
  const std::string rest = "0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0";
  const std::string pose = "[0,0,0, 30,0,0," + rest + "]";  // joint 1 turned by 30 rad
  const std::string flat = "[0,0,0, 0,0,0," + rest + "]";
  CHECK(error_of(path, "{\"poses\": [{\"pose\": " + flat + "}, {\"pose\": " + pose + "}]}") ==
        path + ": poses[1]: pose[3..5] rotates joint 1 by 30 rad, more than 2 pi");
  CHECK(error_of(path, "{\"poses\": [{\"pose\": " + flat + ", \"trans\": [0, 1e30, 0]}]}") ==
        path + ": poses[0]: trans[1] = 1e+30 m is more than 10 m from the capture's origin");
  CHECK(error_of(path, "{\"interpolate\": {\"from\": {\"pose\": " + flat + "}, \"to\": {\"pose\": " + flat +
                           ", \"shape\": [0,0,0,0,0,0,0,0,0,40]}}}") ==
        path + ": interpolate.to: shape[9] = 40 is beyond +-10 standard deviations: not a hand");
}
