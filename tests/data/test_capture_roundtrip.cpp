// Round trip: synthesise the tiny capture in the InterHand2.6M layout, read it back with the real
// reader, and check counts, splits, cameras, MANO parameters, masks against the synthetic
// renderer's own coverage, joint projections, ROI crops, the disk mask cache and the LRU cache.
#include <algorithm>
#include <filesystem>
#include <set>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "data/roi.h"
#include "data_test_helpers.h"
#include "mask_iou.h"
#include "synth_fixture.h"

// Catch last: LibTorch pulls in glog, whose CHECK macro would otherwise replace Catch's.
#include <catch2/catch.hpp>

using namespace handscs;

namespace {

int camera_index(const SynthScene& scene, const std::string& id) {
  for (size_t i = 0; i < scene.cameras.size(); ++i)
    if (scene.cameras[i].id == id) return static_cast<int>(i);
  return -1;
}

int frame_index(const SynthScene& scene, int64_t frame_idx) {
  for (size_t i = 0; i < scene.frames.size(); ++i)
    if (scene.frames[i].frame_idx == frame_idx) return static_cast<int>(i);
  return -1;
}

}  // namespace

TEST_CASE("capture roundtrip: counts, split sizes, cameras and MANO parameters") {
  const auto& tiny = data_test::tiny_capture();
  Capture capture = Capture::open(data_test::tiny_config(tiny.root));
  CHECK(capture.frames().size() == 48);
  CHECK(capture.num_poses() == 12);
  CHECK(capture.train().size() == 9 * 4);  // novel_pose: 3 of 12 poses held out
  CHECK(capture.test().size() == 3 * 4);
  CHECK(capture.cameras().size() == 4);
  CHECK(capture.monochrome_cameras().empty());
  CHECK(capture.skipped().empty());
  CHECK(capture.skip_summary().empty());
  // Held-out poses are the last ones by frame index.
  int64_t last_train = -1, first_test = 1 << 30;
  for (const auto& f : capture.train()) last_train = std::max(last_train, f.frame_idx);
  for (const auto& f : capture.test()) first_test = std::min(first_test, f.frame_idx);
  CHECK(last_train < first_test);
  CHECK(first_test == tiny.scene.frames[9].frame_idx);

  for (const FrameInfo& f : capture.frames()) {
    const int c = camera_index(tiny.scene, f.camera_id);
    const int k = frame_index(tiny.scene, f.frame_idx);
    REQUIRE(c >= 0);
    REQUIRE(k >= 0);
    CHECK(capture.frames()[f.index].image_path == f.image_path);
    CHECK(std::filesystem::exists(f.image_path));
    const Camera& expected = tiny.scene.cameras[c].camera;
    for (int i = 0; i < 9; ++i) {
      CHECK(f.camera.K[i] == Approx(expected.K[i]).margin(1e-9));
      CHECK(f.camera.R[i] == Approx(expected.R[i]).margin(1e-12));
    }
    for (int i = 0; i < 3; ++i) CHECK(f.camera.t[i] == Approx(expected.t[i]).margin(1e-12));
    CHECK(f.camera.width == expected.width);
    CHECK(f.camera.height == expected.height);
    const SynthFrame& sf = tiny.scene.frames[k];
    for (int i = 0; i < 48; ++i) CHECK(f.pose[i] == Approx(sf.annotated[i]).margin(1e-6));
    for (int i = 0; i < 10; ++i) CHECK(f.shape[i] == Approx(sf.absolute.shape[i]).margin(1e-6));
    for (int i = 0; i < 3; ++i) CHECK(f.trans[i] == Approx(sf.trans[i]).margin(1e-6));
    // joint_3d (mm, InterHand order) comes back in metres and MANO21 order.
    for (int i = 0; i < 63; ++i) CHECK(f.joints[i] == Approx(sf.joints[i]).margin(1e-6));
    for (int j = 0; j < 21; ++j) CHECK(f.joint_valid[j] == 1);
    // The posed rig of the reader matches the generator's (pose relative to hands_mean).
    const auto& posed = capture.posed_vertices(f.pose_index);
    REQUIRE(posed.size() == sf.vertices.size());
    for (size_t i = 0; i < posed.size(); i += 97)
      CHECK(posed[i] == Approx(sf.vertices[i]).margin(1e-6));
  }
}

TEST_CASE("capture roundtrip: masks cover the rendered hand (IoU >= 0.98)") {
  const auto& tiny = data_test::tiny_capture();
  Capture capture = Capture::open(data_test::tiny_config(tiny.root));
  double min_iou_centre = 1, min_iou_antialiased = 1;
  for (const FrameInfo& f : capture.frames()) {
    const SynthView view = render_synth_frame(tiny.scene, frame_index(tiny.scene, f.frame_idx),
                                              camera_index(tiny.scene, f.camera_id));
    const FrameSample sample = capture.load(f, true);
    REQUIRE(sample.mask.size(0) == f.camera.height);
    REQUIRE(sample.mask.size(1) == f.camera.width);
    const cv::Mat mask(f.camera.height, f.camera.width, CV_8UC1, sample.mask.data_ptr<uint8_t>());
    // Pixel centres the renderer saw the hand at, and pixels it drew at least half covered.
    const cv::Mat half_covered =
        view.samples >= (tiny.scene.config.supersample * tiny.scene.config.supersample + 1) / 2;
    min_iou_centre = std::min(min_iou_centre, data_test::mask_iou(mask, view.coverage));
    min_iou_antialiased = std::min(min_iou_antialiased, data_test::mask_iou(mask, half_covered));
    CHECK(cv::countNonZero(mask) > 1000);
  }
  INFO("min IoU vs centre coverage " << min_iou_centre << ", vs >= half coverage "
                                     << min_iou_antialiased);
  CHECK(min_iou_centre >= 0.98);
  CHECK(min_iou_antialiased >= 0.98);
}

TEST_CASE("capture roundtrip: annotated joints project onto the hand and into the bbox") {
  const auto& tiny = data_test::tiny_capture();
  Capture capture = Capture::open(data_test::tiny_config(tiny.root));
  int inside = 0, total = 0;
  for (const FrameInfo& f : capture.frames()) {
    const cv::Mat bgr = capture.decode_image(f);
    cv::Mat mask = capture.compute_mask(f, bgr), grown;
    // Fingertip joints are surface vertices: allow 2 px around the silhouette.
    cv::dilate(mask, grown, cv::Mat::ones(5, 5, CV_8UC1));
    for (int j = 0; j < 21; ++j) {
      const auto c =
          f.camera.to_camera({f.joints[j * 3], f.joints[j * 3 + 1], f.joints[j * 3 + 2]});
      const auto uv = f.camera.project_camera(c);
      const int x = static_cast<int>(std::floor(uv[0])), y = static_cast<int>(std::floor(uv[1]));
      ++total;
      INFO(f.file_name << " joint " << j << " at " << uv[0] << ", " << uv[1]);
      REQUIRE(x >= 0);
      REQUIRE(y >= 0);
      REQUIRE(x < f.camera.width);
      REQUIRE(y < f.camera.height);
      inside += grown.at<uint8_t>(y, x) != 0;
      CHECK(uv[0] >= f.bbox[0] - 1);
      CHECK(uv[0] <= f.bbox[0] + f.bbox[2] + 1);
      CHECK(uv[1] >= f.bbox[1] - 1);
      CHECK(uv[1] <= f.bbox[1] + f.bbox[3] + 1);
      // The hand's pixels are skin, not background.
    }
    cv::Scalar hand_mean = cv::mean(bgr, mask), background_mean = cv::mean(bgr, mask == 0);
    CHECK(hand_mean[2] > 60);
    CHECK(background_mean[2] < 15);
  }
  CHECK(inside == total);
}

TEST_CASE("capture roundtrip: ROI crops match the full image and hold the whole mask") {
  const auto& tiny = data_test::tiny_capture();
  CaptureConfig config = data_test::tiny_config(tiny.root);
  config.roi_margin = 7;
  Capture capture = Capture::open(config);
  for (size_t i = 0; i < capture.frames().size(); i += 5) {
    const FrameInfo& f = capture.frames()[i];
    const FrameSample crop = capture.load(f);
    const FrameSample full = capture.load(f, true);
    const cv::Mat full_mask(f.camera.height, f.camera.width, CV_8UC1,
                            full.mask.data_ptr<uint8_t>());
    const PixelRect bounds = mask_bounds(full_mask);
    const PixelRect expected = grow_rect(bounds, 7, f.camera.width, f.camera.height);
    CHECK(crop.roi.x0 == expected.x0);
    CHECK(crop.roi.y0 == expected.y0);
    CHECK(crop.roi.x1 == expected.x1);
    CHECK(crop.roi.y1 == expected.y1);
    CHECK(crop.image.size(0) == crop.roi.height());
    CHECK(crop.image.size(1) == crop.roi.width());
    CHECK(crop.image.size(2) == 3);
    CHECK(crop.mask.sum().item<int64_t>() == full.mask.sum().item<int64_t>());
    using torch::indexing::Slice;
    CHECK(torch::equal(crop.image, full.image.index({Slice(crop.roi.y0, crop.roi.y1),
                                                     Slice(crop.roi.x0, crop.roi.x1)})));
    // RGB order: the red channel of skin is its brightest.
    const cv::Mat bgr = capture.decode_image(f);
    const cv::Vec3b pixel = bgr.at<cv::Vec3b>(crop.roi.y0 + 3, crop.roi.x0 + 4);
    CHECK(crop.image[3][4][0].item<int>() == pixel[2]);
    CHECK(crop.image[3][4][2].item<int>() == pixel[0]);
    // The ROI camera projects like the full camera shifted by the ROI origin.
    const Camera roi_camera = crop.roi_camera();
    CHECK(roi_camera.cx() == Approx(f.camera.cx() - crop.roi.x0));
    CHECK(roi_camera.width == crop.roi.width());
  }
}

TEST_CASE("capture roundtrip: novel_view split, sequences and frame stride") {
  const auto& tiny = data_test::tiny_capture();
  CaptureConfig config = data_test::tiny_config(tiny.root);
  const auto ids = Capture::open(config).cameras();
  config.split_rule = CaptureConfig::SplitRule::novel_view;
  config.test_cameras = {ids[3]};
  Capture view = Capture::open(config);
  CHECK(view.train().size() == 36);
  CHECK(view.test().size() == 12);
  for (const auto& f : view.test()) CHECK(f.camera_id == ids[3]);
  for (const auto& f : view.train()) CHECK(f.camera_id != ids[3]);

  // validation_cameras: a training camera becomes the test set and leaves training; the test
  // camera is not opened.
  config.validation_cameras = {ids[1]};
  Capture validation = Capture::open(config);
  CHECK(validation.train().size() == 24);
  CHECK(validation.test().size() == 12);
  for (const auto& f : validation.test()) CHECK(f.camera_id == ids[1]);
  for (const auto& f : validation.train()) CHECK((f.camera_id == ids[0] || f.camera_id == ids[2]));
  for (const auto& f : validation.frames()) CHECK(f.camera_id != ids[3]);
  config.validation_cameras.clear();

  // No camera lists: 4 cameras, 10:15 asked -> 2 train, 2 test, alternating by sorted id.
  config.test_cameras.clear();
  Capture chosen = Capture::open(config);
  std::set<std::string> train_ids, test_ids;
  for (const auto& f : chosen.train()) train_ids.insert(f.camera_id);
  for (const auto& f : chosen.test()) test_ids.insert(f.camera_id);
  std::vector<std::string> sorted(ids.begin(), ids.end());
  std::sort(sorted.begin(), sorted.end());
  CHECK(train_ids == std::set<std::string>{sorted[0], sorted[2]});
  CHECK(test_ids == std::set<std::string>{sorted[1], sorted[3]});

  config = data_test::tiny_config(tiny.root);
  config.frame_stride = 2;
  config.held_out_poses = 2;
  config.train_cameras = {ids[0], ids[1]};
  Capture strided = Capture::open(config);
  CHECK(strided.num_poses() == 6);
  CHECK(strided.train().size() == 4 * 2);
  CHECK(strided.test().size() == 2 * 2);  // test cameras default to the training cameras
  for (const auto& f : strided.frames())
    CHECK(f.frame_idx % (2 * tiny.scene.config.frame_step) == 0);

  config = data_test::tiny_config(tiny.root);
  config.sequences = {"0000_synth_rom"};
  CHECK(Capture::open(config).frames().size() == 48);
}

TEST_CASE("capture roundtrip: train_poses and validation_poses choose poses before the held-out ones") {
  const auto& tiny = data_test::tiny_capture();
  CaptureConfig config = data_test::tiny_config(tiny.root);
  const Capture all = Capture::open(config);
  config.train_poses = 4;
  const Capture fewer = Capture::open(config);
  // 12 poses, 3 held out: poses 5-8 train, from the 4 cameras; the test images are unchanged.
  CHECK(fewer.train().size() == 4 * 4);
  std::set<int> train_poses;
  for (const auto& f : fewer.train()) train_poses.insert(f.pose_index);
  CHECK(train_poses == std::set<int>{5, 6, 7, 8});
  REQUIRE(fewer.test().size() == all.test().size());
  for (size_t i = 0; i < all.test().size(); ++i)
    CHECK(fewer.test()[i].image_path == all.test()[i].image_path);
  // Every pose before the tail is the same as 0.
  config.train_poses = 9;
  CHECK(Capture::open(config).train().size() == all.train().size());

  // validation_poses: the last 2 training poses (7, 8) are the test set, the held-out poses
  // (9-11) are neither trained nor tested on; with train_poses 3, poses 4-6 train.
  config.train_poses = 3;
  config.validation_poses = 2;
  const Capture validation = Capture::open(config);
  std::set<int> trained, tested;
  for (const auto& f : validation.train()) trained.insert(f.pose_index);
  for (const auto& f : validation.test()) tested.insert(f.pose_index);
  CHECK(trained == std::set<int>{4, 5, 6});
  CHECK(tested == std::set<int>{7, 8});
  CHECK(validation.test().size() == 2 * 4);
}

TEST_CASE("capture roundtrip: novel_view cameras chosen like the paper's 10 train / 15 test") {
  std::set<std::string> available;
  for (int k = 0; k < 40; ++k) available.insert(std::to_string(400002 + 2 * k));
  std::set<std::string> train, test;
  choose_novel_view_cameras(available, 10, 15, train, test);
  CHECK(train.size() == 10);
  CHECK(test.size() == 15);
  for (const auto& id : test) CHECK(!train.count(id));
  // Interleaved: between two consecutive training ids (sorted) there is at least one test id.
  const std::vector<std::string> t(train.begin(), train.end());
  for (size_t k = 0; k + 1 < t.size(); ++k) {
    auto next = test.upper_bound(t[k]);
    CHECK((next != test.end() && *next < t[k + 1]));
  }
  train.clear();
  test.clear();
  choose_novel_view_cameras({"a", "b", "c"}, 10, 15, train, test);
  CHECK(train.size() + test.size() == 3);
  CHECK(!train.empty());
  CHECK(!test.empty());
  train.clear();
  CHECK_THROWS_WITH(choose_novel_view_cameras({"a"}, 10, 15, train, test),
                    "capture: split_rule novel_view needs at least 2 cameras, the capture has 1");
}

TEST_CASE("capture roundtrip: masks are cached on disk and read back") {
  const auto& tiny = data_test::tiny_capture();
  const std::string cache = data_test::fresh_dir("mask_cache");
  CaptureConfig config = data_test::tiny_config(tiny.root);
  std::string folder;
  {
    Capture capture = Capture::open(config, cache);
    folder = capture.mask_cache_folder();
    REQUIRE(!folder.empty());
    capture.load(capture.frames()[0]);
  }
  const FrameInfo first = Capture::open(config).frames()[0];
  const std::filesystem::path png =
      std::filesystem::path(folder) /
      std::filesystem::path(first.file_name).replace_extension(".png");
  REQUIRE(std::filesystem::exists(png));
  // Replace the cached mask by a square: a new capture must use the file, not recompute.
  cv::Mat square(first.camera.height, first.camera.width, CV_8UC1, cv::Scalar(0));
  square(cv::Rect(10, 20, 30, 40)).setTo(255);
  cv::imwrite(png.string(), square);
  {
    Capture capture = Capture::open(config, cache);
    const FrameSample sample = capture.load(capture.frames()[0], true);
    CHECK(sample.mask.sum().item<int64_t>() == 30 * 40);
  }
  // Other mask settings use another folder.
  config.mask_refine.high = 180;
  CHECK(Capture::open(config, cache).mask_cache_folder() != folder);
}

TEST_CASE("capture roundtrip: prefetching loads the same crops and the cache keeps its budget") {
  const auto& tiny = data_test::tiny_capture();
  CaptureConfig config = data_test::tiny_config(tiny.root);
  Capture reference = Capture::open(config);
  config.cache.budget_mb = 1;  // about 25 tiny crops
  config.cache.prefetch_threads = 2;
  Capture capture = Capture::open(config);
  const auto& frames = capture.frames();
  size_t max_bytes = 0;
  for (int pass = 0; pass < 2; ++pass) {
    for (size_t i = 0; i < frames.size(); ++i) {
      std::vector<int64_t> next;
      for (size_t k = i + 1; k < frames.size() && k < i + 4; ++k)
        next.push_back(static_cast<int64_t>(k));
      capture.prefetch(next);
      const FrameSample a = capture.load(frames[i]);
      const FrameSample b = reference.load(reference.frames()[i]);
      CHECK(torch::equal(a.image, b.image));
      CHECK(torch::equal(a.mask, b.mask));
      max_bytes = std::max(max_bytes, capture.cache().bytes());
    }
  }
  CHECK(max_bytes <= capture.cache().budget());
  CHECK(capture.cache().budget() == (size_t(1) << 20));
  CHECK(capture.cache().stats().evictions > 0);
  CHECK(capture.cache().stats().hits > 0);
}
