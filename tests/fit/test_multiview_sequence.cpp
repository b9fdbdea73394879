// A multi-view sequence (a folder per instant beside the camera archive): the hands fitted in
// every instant with one shape per hand, against the joints its landmarks were projected from.
// The archive's camera 0 has no image anywhere, so a view's position differs from its number.
#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>
#include <random>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "data/capture.h"
#include "data/npz_writer.h"
#include "fit/fit_command.h"
#include "fit/multiview_capture.h"
#include "hand/keypoint_order.h"
#include "hand/procedural_hand.h"
#include "captured_warnings.h"
#include "fit_fixtures.h"
#include "test_support.h"

using namespace handscs;
namespace fs = std::filesystem;

namespace {

constexpr int kViews = 8;
constexpr double kNoisePx = 1.0;  // ~0.6 mm at 1 m and 1800 px focal

// The hand's true parameters at instant `k` of the sequence: a bend that changes with k, one shape.
JointParams true_params(const JointModel& model, Handedness side, int k) {
  JointParams p;
  const double bend = 0.4 + 0.5 * k;  // from nearly flat to well curled
  for (int j = 1; j < kRigJoints; ++j)
    for (int i = 0; i < 3; ++i) p.pose[3 * j + i] = bend * model.hands_mean[3 * (j - 1) + i];
  p.pose[0] = 0.3 + 0.2 * k;
  p.pose[1] = side == Handedness::right ? 0.3 : -0.3;
  p.shape[0] = 1.5;  // a larger hand than the mean, the same at every instant
  p.shape[1] = -1.0;
  p.trans = {side == Handedness::right ? -0.12 : 0.12, 0.02 * k, 0.0};
  return p;
}

// MediaPipe's landmark file of one view: x and y over [-1, 1], MediaPipe's joint order.
nlohmann::json landmark_file(const std::array<Detection, 2>& by_side, bool with_left) {
  nlohmann::json doc = {{"Left", nlohmann::json::array()}};  // MediaPipe's "not detected"
  for (int s = 0; s < (with_left ? 2 : 1); ++s) {
    std::vector<double> values(63, 0.0);
    for (int j = 0; j < 21; ++j) {
      const int src = kMano21FromMediaPipe[j];
      values[3 * src] = by_side[s].pixels[j][0] / 1280.0 * 2.0 - 1.0;
      values[3 * src + 1] = by_side[s].pixels[j][1] / 1024.0 * 2.0 - 1.0;
    }
    doc[s == 0 ? "Right" : "Left"] = values;
  }
  return doc;
}

// world_mat_i of a camera: K [R | t] with OpenCV's pixel centres (cx, cy half a pixel less).
data_test::NpzArray world_mat(const Camera& c) {
  data_test::NpzArray a{{4, 4}, std::vector<double>(16, 0.0)};
  const double K[9] = {c.K[0], 0, c.K[2] - 0.5, 0, c.K[4], c.K[5] - 0.5, 0, 0, 1};
  for (int r = 0; r < 3; ++r)
    for (int col = 0; col < 4; ++col) {
      double v = 0;
      for (int k = 0; k < 3; ++k) v += K[3 * r + k] * (col < 3 ? c.R[3 * k + col] : c.t[k]);
      a.values[4 * r + col] = v;
    }
  a.values[15] = 1.0;
  return a;
}

}  // namespace

TEST_CASE("multiview sequence: every instant fitted with one shape per hand; folders without landmarks named") {
  // Instants 0, 5 and 12 with landmarks (folder names with and without zeros); 7 with images only.
  // Instant 5 shows the right hand only; instant 12 lacks view 7 (image and landmarks).
  const std::vector<std::pair<int64_t, std::string>> instants = {{0, "000000"}, {5, "5"}, {12, "000012"}};
  auto shows = [](int64_t frame, int s, int view) { return (frame != 5 || s == 0) && (frame != 12 || view != 7); };
  const std::string root = handscs_test::scratch_path("multiview_sequence", "capture");
  fs::remove_all(root);
  fs::create_directories(root);
  const auto cameras = test::camera_ring(kViews);
  std::map<std::string, data_test::NpzArray> archive;
  // View v (images NN = v) is ring camera v - 1; view 0 has a camera and no image.
  for (int v = 0; v <= kViews; ++v) archive["world_mat_" + std::to_string(v)] = world_mat(cameras[std::max(v - 1, 0)]);
  data_test::write_npz(root + "/cameras.npz", archive);
  const std::array<JointModel, 2> models = {make_joint_model(make_procedural_hand(Handedness::right)),
                                            make_joint_model(make_procedural_hand(Handedness::left))};
  // A plain colour per instant (grey views would be dropped as monochrome), to tell the overlays' instant.
  auto plain = [](int k) { return cv::Mat(1024, 1280, CV_8UC3, cv::Scalar(40, 90, 100 + 40 * k)); };
  std::map<int64_t, std::array<std::array<double, 63>, 2>> truth;
  std::mt19937 rng(3);
  for (size_t k = 0; k < instants.size(); ++k) {
    const auto& [frame, folder] = instants[k];
    fs::create_directories(root + "/" + folder + "/img");
    fs::create_directories(root + "/" + folder + "/pose");
    for (int s = 0; s < 2; ++s)
      joint_positions(models[s], true_params(models[s], s == 0 ? Handedness::right : Handedness::left, k),
                      truth[frame][s].data());
    for (int v = 1; v <= kViews; ++v) {
      if (!shows(frame, 0, v)) continue;
      const std::string name = "0" + std::to_string(v);
      cv::imwrite(root + "/" + folder + "/img/" + name + ".png", plain(k));
      const std::array<Detection, 2> seen = {
          test::project_hand(cameras, v - 1, truth[frame][0].data(), kNoisePx, rng, "Right"),
          test::project_hand(cameras, v - 1, truth[frame][1].data(), kNoisePx, rng, "Left")};
      std::ofstream(root + "/" + folder + "/pose/" + name + ".json") << landmark_file(seen, shows(frame, 1, v)).dump();
    }
  }
  fs::create_directories(root + "/7/img");
  for (int v = 1; v <= kViews; ++v) cv::imwrite(root + "/7/img/0" + std::to_string(v) + ".png", plain(3));

  FitCommandOptions o;
  o.multiview = root;
  o.out = handscs_test::scratch_path("multiview_sequence", "fit");
  o.overwrite = true;
  o.overlay_views = {0};
  o.overlay_frame = 12;
  {
    handscs_test::CapturedWarnings warnings;
    run_fit_command(o);
    CHECK_THAT(warnings.text(), Catch::Contains(root + "/7: no landmark folder (pose/ or landmarks/): frame 7 is "
                                                       "not fitted\n"));
  }

  const auto capture = nlohmann::json::parse(std::ifstream(o.out + "/capture.json"));
  REQUIRE(capture["frames"].size() == 3);
  std::array<std::vector<double>, 2> first_shape;
  for (size_t k = 0; k < instants.size(); ++k) {
    const auto& frame = capture["frames"][k];
    const int64_t number = frame["frame"].get<int64_t>();
    INFO("frame " << number);
    REQUIRE(number == instants[k].first);  // in frame order
    CHECK(frame["hand_type"] == (number == 5 ? "right" : "interacting"));
    CHECK(frame.contains("left") == (number != 5));
    for (int s = 0; s < (number == 5 ? 1 : 2); ++s) {
      const auto& hand = frame[s == 0 ? "right" : "left"];
      // Within 3 mm of the joints the landmarks came from, at every joint: 1 px of noise over 8 views.
      for (int j = 0; j < 21; ++j)
        for (int i = 0; i < 3; ++i)
          CHECK(hand["joints"][j][i].get<double>() == Approx(truth[number][s][3 * j + i]).margin(3e-3));
      // One shape per hand over the sequence, near the true one.
      const auto shape = hand["shape"].get<std::vector<double>>();
      if (first_shape[s].empty()) first_shape[s] = shape;
      CHECK(shape == first_shape[s]);
      CHECK(shape[0] == Approx(1.5).margin(0.2));  // the modes that move joints most: length, palm
      CHECK(shape[1] == Approx(-1.0).margin(0.2));
    }
  }
  // Each instant's images linked under its frame number; overlays of the frame asked for.
  CHECK(fs::read_symlink(o.out + "/images/view03/000005.png") == fs::absolute(root + "/5/img/03.png"));
  CHECK(fs::read_symlink(o.out + "/images/view08/000012.png") == fs::absolute(root + "/000012/img/08.png"));
  CHECK(!fs::exists(o.out + "/images/view07/000012.png"));
  CHECK(!fs::exists(o.out + "/images/view03/000007.png"));
  // The overlay (view 01, the first kept) shows instant 12's photograph at its corner.
  const cv::Mat overlay = cv::imread(o.out + "/overlay/view01.png", cv::IMREAD_COLOR);
  REQUIRE(!overlay.empty());
  CHECK(overlay.at<cv::Vec3b>(0, 0) == plain(2).at<cv::Vec3b>(0, 0));
  const auto reprojection = nlohmann::json::parse(std::ifstream(o.out + "/reprojection.json"));
  for (const char* side : {"right", "left"}) {
    INFO(side);
    CHECK(reprojection[side]["frames"].size() == (side == std::string("right") ? 3u : 2u));
    CHECK(reprojection[side]["frames"]["000000"]["views"].size() == kViews);
    CHECK(reprojection[side]["frames"]["000012"]["views"].size() == kViews - 1);
    CHECK(reprojection[side]["fitted_median_px"].get<double>() < 3.0);
  }

  // The capture.json is the sequence's hands file: the trainer opens the three instants with hands.
  CaptureConfig c;
  c.root = root;
  c.hands_file = o.out + "/capture.json";
  c.split_rule = CaptureConfig::SplitRule::novel_view;
  c.include_interacting = true;
  c.test_cameras = {"view01"};
  c.scan_cache = handscs_test::scratch_path("multiview_sequence", "scans");
  c.cache.prefetch_threads = 0;
  const Capture opened = Capture::open(c, handscs_test::scratch_path("multiview_sequence", "masks"));
  CHECK(opened.train().size() == 3 * (kViews - 1) - 1);  // view 7 is missing at instant 12
  CHECK(opened.test().size() == 3);

  // A frame asked for that has no landmarks is named before any fitting; the fit in --out stays.
  o.overlay_frame = 7;
  CHECK(handscs_test::error_of([&] { run_fit_command(o); }) ==
        "--overlay-frame: " + root + " has no frame 7 with a hand seen by its landmarks");
  CHECK(fs::exists(o.out + "/capture.json"));
}
