// A left-hand capture (synth hand = left) is the mirror image of the right-hand one, and the reader
// sees it so: with data.hand = left and the built-in rig, every pose puts the built-in left hand
// exactly where the mirrored right hand is, each camera projects the mirrored world to the flipped
// image, and images and hand masks are the right capture's flipped left to right.
#include "catch_torch.h"

#include <opencv2/core.hpp>

#include "synth/mirror.h"
#include "synth_fixture.h"

using namespace handscs;

namespace {

const std::string& left_tiny_root() {
  static const std::string root = [] {
    const std::string dir = data_test::fresh_dir("left_tiny");
    SynthScene scene = data_test::tiny_capture().scene;
    scene.config.hand = CaptureConfig::Hands::left;
    write_synth_capture(scene, dir);
    return dir;
  }();
  return root;
}

}  // namespace

TEST_CASE("left hand: the mirrored tiny capture reads back as the right one's mirror image") {
  const CaptureConfig right_config = data_test::tiny_config(data_test::tiny_capture().root);
  CaptureConfig left_config = data_test::tiny_config(left_tiny_root());
  left_config.hand = CaptureConfig::Hands::left;
  Capture right = Capture::open(right_config);
  Capture left = Capture::open(left_config);
  REQUIRE(left.frames().size() == right.frames().size());
  REQUIRE(left.num_poses() == right.num_poses());
  CHECK(left.test().size() == right.test().size());

  // Posing: the built-in left rig under the mirrored MANO annotation (pose (a, -b, -c) per joint,
  // trans x -> -x) gives the right hand's vertices with x negated.
  double worst_vertex = 0;
  for (int p = 0; p < right.num_poses(); ++p) {
    const std::vector<float>& r = right.posed_vertices(p);
    const std::vector<float>& l = left.posed_vertices(p);
    REQUIRE(l.size() == r.size());
    for (size_t v = 0; v < r.size(); v += 3) {
      worst_vertex = std::max<double>(worst_vertex, std::abs(l[v] + r[v]));
      worst_vertex = std::max<double>(worst_vertex, std::abs(l[v + 1] - r[v + 1]));
      worst_vertex = std::max<double>(worst_vertex, std::abs(l[v + 2] - r[v + 2]));
    }
  }
  INFO("largest vertex difference from the mirror: " << worst_vertex << " m");
  CHECK(worst_vertex < 2e-6);  // float32 posing of ~1 m coordinates

  double worst_pixel = 0, worst_image_error = 0, worst_mask_agreement = 1;
  for (size_t k = 0; k < right.frames().size(); ++k) {
    const FrameInfo& fr = right.frames()[k];
    const FrameInfo& fl = left.frames()[k];
    REQUIRE(fl.file_name == fr.file_name);
    CHECK(fl.held_out == fr.held_out);
    // Cameras: a right-hand vertex seen by the right camera at (u, v) is, mirrored, seen by the
    // left camera at (width - u, v).
    const std::vector<float>& verts = right.posed_vertices(fr.pose_index);
    for (size_t v = 0; v < verts.size(); v += 97 * 3) {
      const auto uv = fr.camera.project_camera(fr.camera.to_camera({verts[v], verts[v + 1], verts[v + 2]}));
      const auto uv_left =
          fl.camera.project_camera(fl.camera.to_camera({-verts[v], verts[v + 1], verts[v + 2]}));
      worst_pixel = std::max(worst_pixel, std::abs(uv_left[0] - (fr.camera.width - uv[0])));
      worst_pixel = std::max(worst_pixel, std::abs(uv_left[1] - uv[1]));
    }
    if (k % 6 != 0) continue;  // decoding and masks: every 6th image is enough
    const cv::Mat right_image = right.decode_image(fr);
    const cv::Mat left_image = left.decode_image(fl);
    cv::Mat flipped;
    cv::flip(right_image, flipped, 1);
    const double image_error = cv::norm(left_image, flipped, cv::NORM_L1) / left_image.total() / 3;
    worst_image_error = std::max(worst_image_error, image_error);
    cv::Mat right_mask = right.compute_mask(fr, right_image), flipped_mask;
    cv::flip(right_mask, flipped_mask, 1);
    const cv::Mat left_mask = left.compute_mask(fl, left_image);
    const double hand = std::max(cv::countNonZero(left_mask), cv::countNonZero(flipped_mask));
    const double agree = 1.0 - cv::countNonZero(left_mask != flipped_mask) / std::max(hand, 1.0);
    worst_mask_agreement = std::min(worst_mask_agreement, agree);
  }
  INFO("projection " << worst_pixel << " px, image " << worst_image_error
                     << " grey levels mean absolute, mask agreement " << worst_mask_agreement);
  CHECK(worst_pixel < 1e-3);
  // The flipped image is JPEG-coded again on another 8x8 grid (quality 95): about a grey level.
  CHECK(worst_image_error < 1.5);
  // Mask pixels that differ, over the hand's pixels: refinement sees the re-coded image.
  CHECK(worst_mask_agreement > 0.99);
}

TEST_CASE("left hand: a rig of the other hand is refused, naming data.rig and data.hand") {
  CaptureConfig config = data_test::tiny_config(left_tiny_root());
  config.hand = CaptureConfig::Hands::left;
  config.rig = "builtin:right";
  CHECK(data_test::error_of([&] { Capture::open(config); }) ==
        "data.rig: rig \"builtin:right\" is a right hand but data.hand is left");
}

TEST_CASE("left hand: mirroring a camera, a pose, a point and a box") {
  InterHandCamera camera;
  camera.campos_mm = {100, 200, 300};
  camera.camrot = {1, 2, 3, 4, 5, 6, 7, 8, 9};
  camera.focal = {1200, 1210};
  camera.princpt = {160, 250};
  const InterHandCamera m = mirror_interhand_camera(camera, 334);
  CHECK(m.campos_mm == std::array<double, 3>{-100, 200, 300});
  CHECK(m.camrot == std::array<double, 9>{1, -2, -3, -4, 5, 6, -7, 8, 9});
  CHECK(m.focal == camera.focal);
  CHECK(m.princpt == std::array<double, 2>{174, 250});
  std::array<double, 48> pose{};
  for (int i = 0; i < 48; ++i) pose[i] = i + 1;
  const std::array<double, 48> mirrored = mirror_mano_pose(pose);
  for (int i = 0; i < 48; ++i) CHECK(mirrored[i] == (i % 3 == 0 ? pose[i] : -pose[i]));
  CHECK(mirror_point({1, 2, 3}) == std::array<double, 3>{-1, 2, 3});
  CHECK(mirror_box({10, 20, 30, 40}, 100) == std::array<double, 4>{60, 20, 30, 40});
}
