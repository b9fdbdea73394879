// Two-hand synthetic captures (synth preset both_tiny, hand both) read back by the real reader in
// every layout: each hand's annotations pose the built-in rig of its side onto the mesh the
// generator drew (an independent check of the reflection that makes the left hand), masks cover
// the rendered pair, and the hands come close enough to touch and hide each other.
#include <algorithm>
#include <cmath>
#include <map>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "data_test_helpers.h"
#include "mask_iou.h"
#include "synth_fixture.h"
#include "hand/lbs.h"
#include "synth/left_hand.h"

// Catch last: LibTorch pulls in glog, whose CHECK macro would otherwise replace Catch's.
#include <catch2/catch.hpp>

using namespace handscs;

namespace {

struct TwoHandCapture {
  SynthScene scene;
  std::string root;
};

// both_tiny written in `layout`, once per process.
const TwoHandCapture& two_hand_capture(const std::string& layout) {
  static std::map<std::string, TwoHandCapture> captures;
  auto it = captures.find(layout);
  if (it != captures.end()) return it->second;
  TwoHandCapture capture;
  capture.root = data_test::fresh_dir("two_hands_" + layout);
  SynthConfig config = synth_preset("both_tiny");
  config.layout = choice_value(layout, SynthConfig::layout_names());
  capture.scene = make_synth_scene(config);
  write_synth_capture(capture.scene, capture.root);
  return captures.emplace(layout, std::move(capture)).first->second;
}

CaptureConfig two_hand_config(const std::string& root, const std::string& layout) {
  CaptureConfig config = data_test::tiny_config(root);
  config.hand = CaptureConfig::Hands::both;
  config.layout = choice_value(layout, CaptureConfig::layout_names());
  return config;
}

int index_of_camera(const SynthScene& scene, const std::string& id) {
  for (size_t i = 0; i < scene.cameras.size(); ++i)
    if (scene.cameras[i].id == id) return static_cast<int>(i);
  return -1;
}

}  // namespace

TEST_CASE("two-hand capture: the preset makes a left hand beside the right one") {
  const SynthConfig config = synth_preset("real_both_tiny");
  CHECK(config.hand == CaptureConfig::Hands::both);
  CHECK(config.effects.tissue);
  const SynthScene scene = make_synth_scene(synth_preset("both_tiny"));
  REQUIRE(scene.left_frames.size() == scene.frames.size());
  for (size_t k = 0; k < scene.frames.size(); ++k) {
    const SynthFrame& right = scene.frames[k];
    const SynthFrame& left = scene.left_frames[k];
    // Same person: the same shape; its own motion.
    CHECK(left.absolute.shape == right.absolute.shape);
    CHECK(left.absolute.pose != right.absolute.pose);
    // Thumbs towards each other: the right hand's thumb base (MANO21 joint 13) lies on the +z
    // side of its pinky base (joint 7), towards the left hand, and the left one's on the -z side.
    CHECK(right.joints[13 * 3 + 2] > right.joints[7 * 3 + 2]);
    CHECK(left.joints[13 * 3 + 2] < left.joints[7 * 3 + 2]);
    CHECK(right.joints[2] < left.joints[2]);
  }
}

TEST_CASE("two-hand capture: reflected_left_pose composes with the reflection") {
  // Posing the right rig and reflecting through z = 0 equals posing the left rig with the
  // reflected pose, up to a translation (the left rig turns about its own root).
  const Rig right = load_rig_source("builtin"), left = load_rig_source("builtin:left");
  std::array<double, 48> pose{};
  for (int i = 0; i < 48; ++i) pose[i] = 0.3 * std::sin(1.7 * i + 0.4);
  std::array<double, 48> mirrored = reflected_left_pose(pose);
  const auto options = torch::TensorOptions().dtype(torch::kFloat64);
  LbsOptions flat;
  flat.flat_hand_mean = true;
  const torch::Tensor shape = torch::zeros({1, 10}, options), trans = torch::zeros({1, 3}, options);
  torch::Tensor a = lbs(right, torch::from_blob(pose.data(), {1, 48}, options).clone(), shape,
                        trans, flat).vertices[0];
  const torch::Tensor b = lbs(left, torch::from_blob(mirrored.data(), {1, 48}, options).clone(),
                              shape, trans, flat).vertices[0];
  a.select(1, 2).mul_(-1);
  const torch::Tensor offset = (a - b).mean(0);
  CHECK((a - b - offset).abs().max().item<double>() < 1e-9);
}

TEST_CASE("two-hand capture: every layout reads both hands back as generated") {
  for (const std::string layout : {"interhand", "handscs", "easymocap"}) {
    INFO(layout);
    const TwoHandCapture& two = two_hand_capture(layout);
    Capture capture = Capture::open(two_hand_config(two.root, layout));
    CHECK(capture.skipped().empty());
    CHECK(capture.frames().size() == two.scene.frames.size() * two.scene.cameras.size());
    for (const FrameInfo& f : capture.frames()) {
      int k = 0;
      while (two.scene.frames[k].frame_idx != f.frame_idx) ++k;
      for (Handedness side : {Handedness::right, Handedness::left}) {
        const HandParams* hand = f.hand(side);
        REQUIRE(hand != nullptr);
        for (int j = 0; j < 21; ++j) CHECK(hand->joint_valid[j] == 1);
      }
      // The reader poses each hand with its own side's rig from the annotations: right then left,
      // onto the meshes the generator drew (the left one by reflection).
      const std::vector<float>& posed = capture.posed_vertices(f.pose_index);
      const std::vector<float>& right = two.scene.frames[k].vertices;
      const std::vector<float>& left = two.scene.left_frames[k].vertices;
      REQUIRE(posed.size() == right.size() + left.size());
      double worst = 0;
      for (size_t i = 0; i < right.size(); ++i)
        worst = std::max(worst, double(std::abs(posed[i] - right[i])));
      for (size_t i = 0; i < left.size(); ++i)
        worst = std::max(worst, double(std::abs(posed[right.size() + i] - left[i])));
      CHECK(worst < 2e-6);  // metres: float rounding of vertices a metre from the origin
    }
  }
}

TEST_CASE("two-hand capture: masks cover both rendered hands (IoU >= 0.98)") {
  const TwoHandCapture& two = two_hand_capture("interhand");
  Capture capture = Capture::open(two_hand_config(two.root, "interhand"));
  double min_iou = 1;
  for (const FrameInfo& f : capture.frames()) {
    int k = 0;
    while (two.scene.frames[k].frame_idx != f.frame_idx) ++k;
    const SynthView view = render_synth_frame(two.scene, k, index_of_camera(two.scene, f.camera_id));
    const FrameSample sample = capture.load(f, true);
    const cv::Mat mask(f.camera.height, f.camera.width, CV_8UC1, sample.mask.data_ptr<uint8_t>());
    min_iou = std::min(min_iou, data_test::mask_iou(mask, view.coverage));
  }
  INFO("min IoU " << min_iou);
  CHECK(min_iou >= 0.98);
}

TEST_CASE("two-hand capture: the hands touch and hide each other") {
  const TwoHandCapture& two = two_hand_capture("interhand");
  // Closest approach of the two meshes per frame (brute force over vertex pairs).
  double nearest = INFINITY, farthest = 0;
  for (size_t k = 0; k < two.scene.frames.size(); ++k) {
    const std::vector<float>& a = two.scene.frames[k].vertices;
    const std::vector<float>& b = two.scene.left_frames[k].vertices;
    double closest = INFINITY;
    for (size_t i = 0; i < a.size(); i += 3)
      for (size_t j = 0; j < b.size(); j += 3) {
        const double dx = a[i] - b[j], dy = a[i + 1] - b[j + 1], dz = a[i + 2] - b[j + 2];
        closest = std::min(closest, dx * dx + dy * dy + dz * dz);
      }
    nearest = std::min(nearest, std::sqrt(closest));
    farthest = std::max(farthest, std::sqrt(closest));
  }
  INFO("closest approach " << nearest * 1e3 << " mm; widest frame " << farthest * 1e3 << " mm");
  CHECK(nearest < 0.003);
  CHECK(farthest > 0.01);
  // Occlusion: in some image each hand's own mask overlaps the other's, so one hides the other.
  const std::string& root = two.root;
  CaptureConfig config = two_hand_config(root, "interhand");
  config.hand = CaptureConfig::Hands::right;
  config.include_interacting = true;
  Capture right = Capture::open(config);
  config.hand = CaptureConfig::Hands::left;
  Capture left = Capture::open(config);
  REQUIRE(right.frames().size() == left.frames().size());
  int64_t overlapping_images = 0;
  for (size_t i = 0; i < right.frames().size(); ++i) {
    const FrameInfo& r = right.frames()[i];
    const FrameInfo& l = left.frames()[i];
    REQUIRE(r.image_path == l.image_path);
    const cv::Mat image = right.decode_image(r);
    cv::Mat both;
    cv::bitwise_and(right.compute_mask(r, image), left.compute_mask(l, image), both);
    if (cv::countNonZero(both) > 20) ++overlapping_images;
  }
  INFO(overlapping_images << " of " << right.frames().size() << " images show one hand over the other");
  CHECK(overlapping_images >= 4);
}
