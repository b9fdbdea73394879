// Multi-view hands: grouping detections whose labels cannot be trusted, the NeuS/IDR camera
// archive's numpy reader, and the real FMHR capture end to end (its cameras: tests/data).
#include <catch2/catch.hpp>

#include <algorithm>
#include <filesystem>
#include <fstream>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "data/capture.h"
#include "fit/fit_command.h"
#include "fit/multiview_capture.h"
#include "hand/procedural_hand.h"
#include "io/npz.h"
#include "fit_fixtures.h"
#include "captured_warnings.h"
#include "test_support.h"

using namespace handscs;
namespace fs = std::filesystem;

namespace {

const std::string kFmhr = std::string(HANDSCS_SHARED_DIR) + "/testdata/fmhr_demo";

// Joints of the built-in hand (right or left) at a bent pose, moved to `offset`.
std::array<double, 63> hand_joints(Handedness side, const Vec3& offset) {
  const JointModel model = make_joint_model(make_procedural_hand(side));
  JointParams p;
  for (int k = 1; k < kRigJoints; ++k)
    for (int i = 0; i < 3; ++i) p.pose[3 * k + i] = model.hands_mean[3 * (k - 1) + i];
  p.pose[0] = 0.4;
  p.pose[1] = side == Handedness::right ? 0.3 : -0.3;
  for (int i = 0; i < 3; ++i) p.trans[i] = offset[i];
  std::array<double, 63> x;
  joint_positions(model, p, x.data());
  return x;
}

}  // namespace

TEST_CASE("find_hands: two hands from detections with swapped labels, a missed hand and bad views") {
  const auto cameras = test::camera_ring(10);
  std::mt19937 rng(7);
  const auto right = hand_joints(Handedness::right, {-0.12, 0, 0});
  const auto left = hand_joints(Handedness::left, {0.12, 0, 0});
  std::vector<Detection> detections;
  std::vector<int> truth;  // 0 right, 1 left, -1 garbage
  for (int v = 0; v < 10; ++v) {
    const bool swap = v % 3 == 0;  // the detector calls the hands the other way in these views
    if (v != 4) {                  // view 4 misses the right hand
      detections.push_back(test::project_hand(cameras, v, right.data(), 2.0, rng, swap ? "Left" : "Right"));
      truth.push_back(0);
    }
    detections.push_back(test::project_hand(cameras, v, left.data(), 2.0, rng, swap ? "Right" : "Left"));
    truth.push_back(1);
  }
  // View 7's left detection has three index-finger landmarks 60 px off (a mislabelled finger).
  for (size_t d = 0; d < detections.size(); ++d)
    if (detections[d].view == 7 && truth[d] == 1)
      for (int j : {2, 3, 17}) detections[d].pixels[j][0] += 60.0;
  const auto hands = find_hands(cameras, detections, MultiviewConfig{});
  REQUIRE(hands.size() == 2);
  for (const TriangulatedHand& h : hands) {
    const int who = truth[h.detections[0]];
    for (int d : h.detections) CHECK(truth[d] == who);  // no detection of the other hand
    CHECK(h.detections.size() == (who == 0 ? 9u : 10u));
    const auto& joints = who == 0 ? right : left;
    for (int j = 0; j < 21; ++j) {
      REQUIRE(h.keypoints.valid[j]);
      const Vec3 a{h.keypoints.joints[3 * j], h.keypoints.joints[3 * j + 1], h.keypoints.joints[3 * j + 2]};
      const Vec3 b{joints[3 * j], joints[3 * j + 1], joints[3 * j + 2]};
      CHECK(norm(a - b) < 2e-3);  // 2 px of noise at 1 m and 1800 px focal: ~1 mm
    }
    if (who == 1)  // the moved landmarks of view 7 are dropped, the rest of view 7 kept
      for (int j : {2, 3, 17}) CHECK(std::count(h.dropped_views[j].begin(), h.dropped_views[j].end(), 7) == 1);
  }
}

TEST_CASE("find_hands: one hand's detections beyond the inlier bound are that hand again, not a second") {
  const auto cameras = test::camera_ring(10);
  std::mt19937 rng(11);
  const auto hand = hand_joints(Handedness::right, {0, 0, 0});
  // Views 6-9 see the hand 15 mm higher, as a detector's consistent error would place it: 27 px
  // at 1 m and 1800 px focal in every view of the ring, beyond a 10 px bound, and in agreement
  // with each other.
  const auto moved = hand_joints(Handedness::right, {0, 0.015, 0});
  std::vector<Detection> detections;
  for (int v = 0; v < 10; ++v)
    detections.push_back(test::project_hand(cameras, v, (v < 6 ? hand : moved).data(), 1.0, rng, "Left"));
  MultiviewConfig config;
  config.inlier_px = 10.0;
  const auto hands = find_hands(cameras, detections, config);
  REQUIRE(hands.size() == 1);
  CHECK(hands[0].detections.size() == 6u);
  std::vector<int> repeated = hands[0].repeated_detections;
  std::sort(repeated.begin(), repeated.end());
  CHECK(repeated == std::vector<int>{6, 7, 8, 9});
  // Allowed one hand, the same.
  config.max_hands = 1;
  CHECK(find_hands(cameras, detections, config).size() == 1);
}

TEST_CASE("find_hands: two real hands as close as a phantom are both kept, each seen beside the other") {
  const auto cameras = test::camera_ring(10);
  std::mt19937 rng(12);
  // Two hands 25 mm apart, joint for joint (as close as palm to palm; their sides do not matter here).
  const auto first = hand_joints(Handedness::right, {0, 0, 0});
  const auto second = hand_joints(Handedness::right, {0, 0.025, 0});
  double mean_mm = 0;
  for (int j = 0; j < 21; ++j)
    mean_mm += 1000.0 * norm(Vec3{first[3 * j] - second[3 * j], first[3 * j + 1] - second[3 * j + 1],
                                  first[3 * j + 2] - second[3 * j + 2]}) / 21.0;
  REQUIRE(mean_mm < 40.0);  // closer than the phantom bound: the views decide
  std::vector<Detection> detections;
  for (int v = 0; v < 10; ++v) {
    detections.push_back(test::project_hand(cameras, v, first.data(), 1.0, rng, "Left"));
    detections.push_back(test::project_hand(cameras, v, second.data(), 1.0, rng, "Right"));
  }
  MultiviewConfig config;
  config.inlier_px = 10.0;
  const auto hands = find_hands(cameras, detections, config);
  REQUIRE(hands.size() == 2);
  for (const TriangulatedHand& h : hands) {
    CHECK(h.detections.size() == 10u);
    CHECK(h.repeated_detections.empty());
  }
}

TEST_CASE("npz: FMHR's camera archive reads as numpy wrote it") {
  const auto arrays = read_npz(kFmhr + "/camera/param.npz");
  CHECK(arrays.size() == 64);  // int, ext, world_mat, scale_mat for 16 views
  const NpyArray& k0 = arrays.at("int_0");
  REQUIRE(k0.shape == std::vector<int64_t>{4, 4});
  // Values numpy prints for int_0.
  CHECK(k0.values[0] == Approx(2342.95610).epsilon(1e-8));
  CHECK(k0.values[2] == Approx(673.368735).epsilon(1e-8));
  CHECK(k0.values[5] == Approx(2348.24172).epsilon(1e-8));
  CHECK(arrays.at("ext_1").values[3] == Approx(0.26338636).epsilon(1e-7));
  CHECK_THROWS_WITH(read_npz(kFmhr + "/img/00.png"), Catch::Contains("not a ZIP archive"));
}

TEST_CASE("FMHR: both hands fitted from the 16 views' landmarks, closer to them than plain DLT") {
  const MultiviewCapture cap = read_multiview_capture(kFmhr);
  REQUIRE(cap.cameras.size() == 16);
  REQUIRE(cap.instants.size() == 1);
  CHECK(!cap.sequence);
  CHECK(cap.instants[0].detections.size() >= 16);
  FitCommandOptions o;
  o.multiview = kFmhr;
  o.out = handscs_test::scratch_path("fit_fmhr", "out");
  o.overwrite = true;
  o.overlay_views = {0};
  run_fit_command(o);
  std::ifstream in(o.out + "/reprojection.json");
  const auto r = nlohmann::json::parse(in);
  for (const char* side : {"right", "left"}) {
    INFO(side);
    REQUIRE(r.contains(side));
    CHECK(r[side]["frames"]["000000"]["views"].size() >= 8);
    // The shared README measures plain DLT over every detection at a median of 16-21 px.
    CHECK(r[side]["triangulated_median_px"].get<double>() < 16.0);
    CHECK(r[side]["fitted_median_px"].get<double>() < 16.0);
  }
  CHECK(fs::exists(o.out + "/capture.json"));
  CHECK(fs::exists(o.out + "/overlay/view00.png"));
  CHECK(fs::is_symlink(o.out + "/images/view00/000000.png"));
  // The capture's masks linked, and again as the region "hands" (bit 1) that handscs-eval scores.
  CHECK(fs::read_symlink(o.out + "/masks/view03/000000.png") == fs::absolute(kFmhr + "/mask/03.png"));
  const auto legend = nlohmann::json::parse(std::ifstream(o.out + "/regions/regions.json"));
  CHECK(legend["regions"][0]["name"] == "hands");
  CHECK(legend["regions"][0]["bit"] == 1);
  const cv::Mat mask = cv::imread(kFmhr + "/mask/03.png", cv::IMREAD_GRAYSCALE);
  const cv::Mat region = cv::imread(o.out + "/regions/view03/000000.png", cv::IMREAD_UNCHANGED);
  REQUIRE(region.type() == CV_8UC1);
  CHECK(cv::countNonZero(region != ((mask > 127) / 255)) == 0);
  CHECK(cv::countNonZero(region) > 0);

  // The capture.json written is the neus layout's hands file as it is: FMHR's folder trains in place.
  CaptureConfig c;
  c.root = kFmhr;
  c.hands_file = o.out + "/capture.json";
  c.split_rule = CaptureConfig::SplitRule::novel_view;
  c.include_interacting = true;  // both hands were fitted
  c.test_cameras = {"view02", "view06", "view10", "view14"};
  c.scan_cache = handscs_test::scratch_path("fit_fmhr", "scans");
  c.cache.prefetch_threads = 0;
  const Capture capture = Capture::open(c, handscs_test::scratch_path("fit_fmhr", "masks"));
  CHECK(capture.layout() == CaptureConfig::Layout::neus);
  CHECK(capture.train().size() == 12);
  CHECK(capture.test().size() == 4);
}

TEST_CASE("multiview: missing, numbered-for-no-view and out-of-range landmark files are named") {
  // A copy of FMHR's capture (its images linked) whose landmark files are then damaged.
  const std::string root = handscs_test::scratch_path("multiview_bad", "capture");
  fs::remove_all(root);
  fs::create_directories(root);
  for (const char* folder : {"camera", "img", "mask"}) fs::create_directory_symlink(fs::absolute(kFmhr + "/" + folder), root + "/" + folder);
  // No landmark folder: said so, not "no hand is seen by 2 views".
  CHECK(handscs_test::error_of([&] { read_multiview_capture(root); }) ==
        root + ": no landmark folder (pose/ or landmarks/, a NN.json of MediaPipe's landmarks for each "
               "view NN; docs/FIT.md)");
  fs::create_directory(root + "/pose");
  CHECK(handscs_test::error_of([&] { read_multiview_capture(root); }) ==
        root + "/pose: no landmark file of any view (NN.json, numbered as the views' images)");
  for (const auto& entry : fs::directory_iterator(kFmhr + "/pose"))
    fs::copy_file(entry.path(), root + "/pose/" + entry.path().filename().string());
  // A file numbered for no view is named in a warning; the others are read.
  fs::copy_file(kFmhr + "/pose/03.json", root + "/pose/16.json");
  {
    handscs_test::CapturedWarnings warnings;
    CHECK(read_multiview_capture(root).cameras.size() == 16);
    CHECK(warnings.text() == root + "/pose/16.json: no view of that number has a camera and an image; "
                                    "its landmarks are not used\n");
  }
  // Landmarks in pixels rather than the image's [-1, 1]: the file, the hand and the value named.
  auto doc = nlohmann::json::parse(std::ifstream(kFmhr + "/pose/03.json"));
  doc["Right"][4] = 1e300;
  std::ofstream(root + "/pose/03.json") << doc.dump();
  CHECK(handscs_test::error_of([&] { read_multiview_capture(root); }) ==
        root + "/pose/03.json: Right[4] = 1e+300: landmarks are the image's [-1, 1] (one past 4 lies "
               "images away from it); are they pixels?");
}
