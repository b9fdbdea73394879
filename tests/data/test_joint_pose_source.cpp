// data.pose_source = joints: the InterHand2.6M-layout capture opened without its MANO file, the
// hand fitted to joint_3d.json. The fitted hand's masks against the annotated MANO's, the fit
// cache read on the second open, poor fits skipped by name, and other layouts refused.
#include <filesystem>
#include <random>

#include <nlohmann/json.hpp>

#include <opencv2/core.hpp>

#include "core/atomic_file.h"
#include "data_test_helpers.h"
#include "synth_fixture.h"

// Catch last: LibTorch pulls in glog, whose CHECK macro would otherwise replace Catch's.
#include <catch2/catch.hpp>

using namespace handscs;
namespace fs = std::filesystem;

namespace {

CaptureConfig joints_config(const std::string& root, const std::string& cache) {
  CaptureConfig c = data_test::tiny_config(root);
  c.pose_source = CaptureConfig::PoseSource::joints;
  c.annotation_cache = cache;
  return c;
}

std::vector<std::string> fit_cache_files(const std::string& cache) {
  std::vector<std::string> files;
  for (const auto& e : fs::recursive_directory_iterator(cache))
    if (e.path().filename().string().find(".fit-right-") != std::string::npos) files.push_back(e.path().string());
  return files;
}

}  // namespace

TEST_CASE("pose_source joints: the fitted hand covers the annotated MANO hand's pixels") {
  const std::string root = data_test::tiny_capture_in("interhand");
  const std::string cache = data_test::fresh_dir("joint_fit_cache");
  Capture reference = Capture::open(data_test::tiny_config(root));
  Capture fitted = Capture::open(joints_config(root, cache));
  REQUIRE(fitted.frames().size() == reference.frames().size());
  CHECK(fitted.skipped().empty());
  double worst_iou = 1.0;
  for (size_t i = 0; i < fitted.frames().size(); ++i) {
    const FrameInfo& f = fitted.frames()[i];
    const FrameInfo& r = reference.frames()[i];
    REQUIRE(f.frame_idx == r.frame_idx);
    const cv::Mat image = reference.decode_image(r);
    const cv::Mat a = fitted.compute_mask(f, image) > 127, b = reference.compute_mask(r, image) > 127;
    const double inter = cv::countNonZero(a & b), uni = cv::countNonZero(a | b);
    worst_iou = std::min(worst_iou, uni > 0 ? inter / uni : 1.0);
  }
  // Both hands are the built-in rig: one posed by the generator's annotated MANO parameters (with
  // their simulated fit error), one fitted to the joints it rendered.
  INFO("worst mask IoU " << worst_iou);
  CHECK(worst_iou > 0.8);

  // The second open reads the fits from the cache: the same poses, the cache file untouched.
  const auto files = fit_cache_files(cache);
  REQUIRE(files.size() == 1);
  const std::string bytes = read_file(files[0]);
  Capture again = Capture::open(joints_config(root, cache));
  CHECK(read_file(files[0]) == bytes);
  for (size_t i = 0; i < again.frames().size(); ++i) CHECK(again.frames()[i].pose == fitted.frames()[i].pose);
}

TEST_CASE("pose_source joints: poor fits are skipped by name, other layouts refused") {
  // A copy whose first frame's joints are scattered by up to 6 cm: no hand fits them.
  const std::string root = data_test::fresh_dir("joint_fit_scattered");
  fs::copy(data_test::tiny_capture_in("interhand"), root, fs::copy_options::recursive);
  const std::string joint_file = root + "/annotations/test/InterHand2.6M_test_joint_3d.json";
  nlohmann::json joints = nlohmann::json::parse(read_file(joint_file));
  auto& frames = joints.begin().value();
  const std::string first = frames.begin().key();
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> scatter(-60.0, 60.0);  // mm
  for (int j = 0; j < 21; ++j)
    for (int c = 0; c < 3; ++c) frames[first]["world_coord"][j][c] = frames[first]["world_coord"][j][c].get<double>() + scatter(rng);
  write_file_atomic(joint_file, joints.dump());
  Capture capture = Capture::open(joints_config(root, data_test::fresh_dir("joint_fit_scattered_cache")));
  REQUIRE_FALSE(capture.skipped().empty());
  for (const SkippedImage& s : capture.skipped()) CHECK(s.reason == "poor joint fit");
  CHECK_THAT(capture.skip_summary(), Catch::Contains("poor joint fit"));
  for (const FrameInfo& f : capture.frames()) CHECK(std::to_string(f.frame_idx) != first);

  CaptureConfig own = joints_config(data_test::tiny_capture_in("handscs"), "off");
  CHECK_THAT(data_test::error_of([&] { Capture::open(own); }),
             Catch::Contains("data.pose_source: joints is read from InterHand2.6M's joint_3d.json"));
}
