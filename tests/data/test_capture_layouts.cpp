// The project's own capture layout and EasyMocap's: the tiny synthetic capture written in each
// reads back as the InterHand2.6M one (frames, split, cameras, MANO parameters, masks, images;
// EasyMocap's after undistortion), supplied masks replace the mesh's, undistorted images are
// cached, and malformed captures are errors naming the file, the key and what is wrong.
#include <sys/stat.h>

#include <cmath>
#include <filesystem>
#include <map>
#include <set>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "core/atomic_file.h"
#include "core/config.h"
#include "data/capture_layout.h"
#include "data/easymocap_cameras.h"
#include "data/handscs_capture.h"
#include "data/lens_distortion.h"
#include "captured_warnings.h"
#include "data_test_helpers.h"
#include "synth/own_layouts.h"
#include "synth_fixture.h"

// Catch last: LibTorch pulls in glog, whose CHECK macro would otherwise replace Catch's.
#include <catch2/catch.hpp>

using namespace handscs;
using data_test::error_of;
using nlohmann::json;

namespace {

// Mean absolute difference (levels of 255) of two images over the pixels where `mask` is set.
double mean_abs_difference(const cv::Mat& a, const cv::Mat& b, const cv::Mat& mask) {
  cv::Mat diff;
  cv::absdiff(a, b, diff);
  return cv::mean(diff, mask)[0] / 3 + cv::mean(diff, mask)[1] / 3 + cv::mean(diff, mask)[2] / 3;
}

// Copies the tiny capture in `layout` to `name` with the JPEG images of `cameras` (folder names;
// none: every camera) rewritten as PNGs of the same pixels, as docs/CAPTURE_FORMAT.md allows; an
// InterHand2.6M data.json names the PNGs. Returns the copy's root.
std::string tiny_with_pngs(const std::string& layout, const std::string& name,
                           const std::set<std::string>& cameras = {}) {
  namespace fs = std::filesystem;
  const std::string root = data_test::copy_of_tiny_in(layout, name);
  std::vector<fs::path> jpegs;
  for (const auto& entry : fs::recursive_directory_iterator(root + "/images"))
    if (entry.path().extension() == ".jpg" &&
        (cameras.empty() || cameras.count(entry.path().parent_path().filename().string())))
      jpegs.push_back(entry.path());
  for (const fs::path& jpeg : jpegs) {
    const cv::Mat pixels = cv::imread(jpeg.string(), cv::IMREAD_COLOR);
    REQUIRE(cv::imwrite(fs::path(jpeg).replace_extension(".png").string(), pixels));
    fs::remove(jpeg);
  }
  if (layout == "interhand") {
    const std::string data = root + "/annotations/test/InterHand2.6M_test_data.json";
    json value = parse_json_file(data);
    for (json& image : value["images"]) {
      const fs::path png = fs::path(image["file_name"].get<std::string>()).replace_extension(".png");
      if (fs::exists(root + "/images/test/" + png.string())) image["file_name"] = png.string();
    }
    data_test::write_text(data, value.dump());
  }
  return root;
}

// Frame 5's supplied mask of the capture at `root`: a 30 x 40 box at (40, 60), as a PNG file's bytes
// cut to `keep` of their length (1: whole). Returns the mask's path.
std::string write_supplied_mask(const std::string& root, const FrameInfo& f, double keep = 1.0) {
  cv::Mat supplied(f.camera.height, f.camera.width, CV_8UC1, cv::Scalar(0));
  supplied(cv::Rect(40, 60, 30, 40)).setTo(255);
  std::vector<uchar> png;
  REQUIRE(cv::imencode(".png", supplied, png));
  const std::string mask_file = root + "/masks/" + f.camera_id + "/" + frame_file_stem(f.frame_idx) + ".png";
  std::filesystem::create_directories(std::filesystem::path(mask_file).parent_path());
  data_test::write_text(mask_file, std::string(png.begin(), png.begin() + static_cast<size_t>(keep * png.size())));
  return mask_file;
}

}  // namespace

TEST_CASE("capture layouts: auto detects each layout, and data.layout names it") {
  for (const char* layout : {"interhand", "handscs", "easymocap"}) {
    INFO(layout);
    CHECK(detect_capture_layout(data_test::tiny_capture_in(layout), CaptureConfig::Layout::automatic) ==
          choice_value(layout, CaptureConfig::layout_names()));
  }
  const std::string interhand = data_test::tiny_capture_in("interhand");
  CHECK(error_of([&] {
          CaptureConfig c;
          config_from_json(json{{"layout", "colmap"}}, "data", c);
        }) == "data: layout: unknown value \"colmap\" (known: auto, interhand, handscs, easymocap, neus)");
  CaptureConfig config = data_test::tiny_config(interhand);
  config.layout = CaptureConfig::Layout::handscs;
  CHECK(error_of([&] { Capture::open(config); }) ==
        interhand + "/capture.json: missing (the handscs layout keeps its frames' MANO parameters "
                    "there; docs/CAPTURE_FORMAT.md)");
  // An image replaced by a named pipe is skipped as "not a file", not as missing, in every layout.
  for (const std::string layout : {"interhand", "handscs", "easymocap"}) {
    INFO(layout);
    const std::string root = data_test::copy_of_tiny_in(layout, "piped_image_" + layout);
    std::string image;
    for (const auto& entry : std::filesystem::recursive_directory_iterator(root + "/images"))
      if (entry.path().extension() == ".jpg") image = entry.path().string();
    REQUIRE_FALSE(image.empty());
    std::filesystem::remove(image);
    REQUIRE(::mkfifo(image.c_str(), 0600) == 0);
    const Capture capture = Capture::open(data_test::tiny_config(root));
    REQUIRE(capture.skipped().size() == 1);
    CHECK(capture.skipped()[0].path == image);
    CHECK(capture.skipped()[0].reason == "not a file");
    CHECK(capture.skip_summary().find("skipped 1 of 48 images (not a file 1): " + image) != std::string::npos);
  }
  // A layout's file replaced by a named pipe is named, not passed over for another layout.
  for (const std::string layout : {"handscs", "easymocap"}) {
    const std::string root = data_test::copy_of_tiny_in(layout, "piped_" + layout);
    const std::string file = root + (layout == "handscs" ? "/capture.json" : "/intri.yml");
    std::filesystem::remove(file);
    REQUIRE(::mkfifo(file.c_str(), 0600) == 0);
    CHECK(error_of([&] { detect_capture_layout(root, CaptureConfig::Layout::automatic); }) ==
          file + ": is not a regular file (a named pipe, a device, a folder or a broken link); give a file");
  }
}

TEST_CASE("capture layouts: handscs and easymocap captures read as the InterHand2.6M one") {
  Capture reference = Capture::open(data_test::tiny_config(data_test::tiny_capture_in("interhand")));
  REQUIRE(reference.frames().size() == 48);
  for (const char* layout : {"handscs", "easymocap"}) {
    INFO(layout);
    const bool exact = std::string(layout) == "handscs";
    Capture capture = Capture::open(data_test::tiny_config(data_test::tiny_capture_in(layout)));
    CHECK(capture.layout() == choice_value(layout, CaptureConfig::layout_names()));
    CHECK(capture.region_subfolder().empty());
    REQUIRE(capture.frames().size() == reference.frames().size());
    CHECK(capture.num_poses() == reference.num_poses());
    CHECK(capture.train().size() == reference.train().size());
    CHECK(capture.test().size() == reference.test().size());
    CHECK(capture.cameras() == reference.cameras());
    CHECK(capture.skipped().empty());
    double worst_difference = 0;
    for (size_t i = 0; i < capture.frames().size(); ++i) {
      const FrameInfo& f = capture.frames()[i];
      const FrameInfo& r = reference.frames()[i];
      REQUIRE(f.camera_id == r.camera_id);
      REQUIRE(f.frame_idx == r.frame_idx);
      CHECK(f.held_out == r.held_out);
      CHECK(f.pose == r.pose);  // the same doubles written, so the same floats
      CHECK(f.shape == r.shape);
      CHECK(f.trans == r.trans);
      for (int k = 0; k < 63; ++k) CHECK(f.joints[k] == Approx(r.joints[k]).margin(1e-6));
      CHECK(f.joint_valid == r.joint_valid);
      CHECK(f.camera.width == r.camera.width);
      CHECK(f.camera.height == r.camera.height);
      if (exact) {
        CHECK(f.camera.K == r.camera.K);
        CHECK(f.camera.R == r.camera.R);
        CHECK(f.camera.t == r.camera.t);
      } else {
        // K goes through OpenCV's pixel-centre shift (exact), R through Rodrigues and back.
        CHECK(f.camera.K == r.camera.K);
        for (int k = 0; k < 9; ++k) CHECK(f.camera.R[k] == Approx(r.camera.R[k]).margin(1e-12));
        for (int k = 0; k < 3; ++k) CHECK(f.camera.t[k] == Approx(r.camera.t[k]).margin(1e-15));
      }
      const cv::Mat image = capture.decode_image(f), expected = reference.decode_image(r);
      const cv::Mat mask = reference.compute_mask(r, expected);
      if (exact) {
        CHECK(cv::norm(image, expected, cv::NORM_INF) == 0);
        CHECK(cv::norm(capture.compute_mask(f, image), mask, cv::NORM_INF) == 0);
      } else {
        worst_difference = std::max(worst_difference, mean_abs_difference(image, expected, mask));
      }
    }
    // Distorting and undistorting resample twice (bilinear) and the JPEGs differ: on the hand,
    // the undistorted image stays within a few levels of the pinhole render.
    INFO("worst mean |undistorted - pinhole| on the hand: " << worst_difference << " levels");
    if (!exact) CHECK(worst_difference < 4.0);
    if (!exact) CHECK(worst_difference > 0.0);
  }
}

TEST_CASE("capture layouts: undistortion inverts the synthetic lens on a checkerboard") {
  // A lens four times the synthetic capture's, so that the distortion moves edges by pixels: the
  // distorted board differs from the pinhole one, the undistorted board does not beyond resampling.
  Camera camera;
  camera.K = {1265, 0, 167, 0, 1265, 256, 0, 0, 1};
  camera.width = 334;
  camera.height = 512;
  LensDistortion lens = kSynthLensDistortion;
  for (double& c : lens.coefficients) c *= 4;
  cv::Mat board(camera.height, camera.width, CV_8UC3);
  for (int y = 0; y < board.rows; ++y)
    for (int x = 0; x < board.cols; ++x)
      board.at<cv::Vec3b>(y, x) = ((x / 16 + y / 16) % 2) ? cv::Vec3b(230, 200, 40) : cv::Vec3b(20, 40, 90);
  const cv::Mat distorted = distort_image(board, camera, lens);
  const cv::Mat recovered = undistort_image(distorted, undistort_maps(camera, lens));
  // Inside a margin: at the border the undistorted image needs pixels the lens never recorded.
  const cv::Rect inner(24, 24, camera.width - 48, camera.height - 48);
  const cv::Mat inside(camera.height, camera.width, CV_8UC1, cv::Scalar(0));
  inside(inner).setTo(1);
  const double before = mean_abs_difference(distorted, board, inside);
  const double after = mean_abs_difference(recovered, board, inside);
  INFO("mean |distorted - board| " << before << ", |undistorted - board| " << after << " levels");
  CHECK(before > 10.0);
  CHECK(after < before / 4);
  // No distortion: the maps are the identity.
  const cv::Mat same = undistort_image(board, undistort_maps(camera, LensDistortion{}));
  CHECK(cv::norm(same, board, cv::NORM_INF) == 0);
}

TEST_CASE("capture layouts: a distortion that folds or blackens the image is refused, naming the camera") {
  Camera camera;
  camera.K = {1265, 0, 167, 0, 1265, 256, 0, 0, 1};
  camera.width = 334;
  camera.height = 512;
  const auto problem = [&](const LensDistortion& lens) {
    return distortion_problem(camera, lens, undistort_maps(camera, lens));
  };
  LensDistortion strong = kSynthLensDistortion;
  for (double& c : strong.coefficients) c *= 4;
  CHECK(problem(LensDistortion{}) == "");
  CHECK(problem(kSynthLensDistortion) == "");
  CHECK(problem(strong) == "");
  // k1 = -20: r (1 - 20 r^2) turns back at r = 1/sqrt(60) = 0.129, inside the corners (r = 0.242).
  CHECK(problem(LensDistortion{{-20, 0, 0, 0, 0}}) ==
        "its radial distortion turns back at r = 0.129 (normalised), inside the image (corners at "
        "r = 0.242): part of the image would appear mirrored");
  CHECK(problem(LensDistortion{{1e6, 1e6, 0, 0, 1e6}}).find("from outside the recorded one: the image "
                                                            "would be mostly black") != std::string::npos);

  // In a capture: refused at open, naming the file, the camera and the coefficients.
  const std::string root = data_test::copy_of_tiny_in("handscs", "folding_lens");
  const std::string file = root + "/capture.json";
  json value = parse_json_file(file);
  value["cameras"]["400004"]["dist"] = {-20, 0, 0, 0, 0};
  data_test::write_text(file, value.dump());
  const std::string error = error_of([&] { Capture::open(data_test::tiny_config(root)); });
  INFO(error);
  CHECK(error.find(": camera 400004: its radial distortion turns back") != std::string::npos);
  CHECK(error.find("check its distortion coefficients (k1, k2, p1, p2, k3 = -20, 0, 0, 0, 0)") !=
        std::string::npos);
}

TEST_CASE("capture layouts: undistorted images are cached beside the masks and read back") {
  const std::string root = data_test::tiny_capture_in("easymocap");
  const std::string cache = data_test::fresh_dir("undistort_cache");
  std::vector<cv::Mat> first;
  {
    Capture capture = Capture::open(data_test::tiny_config(root), cache);
    for (int i = 0; i < 4; ++i) first.push_back(capture.decode_image(capture.frames()[i]));
  }
  int cached = 0;
  for (const auto& entry : std::filesystem::recursive_directory_iterator(cache))
    if (entry.path().extension() == ".png" &&
        entry.path().string().find("/undistorted-") != std::string::npos)
      ++cached;
  CHECK(cached == 4);
  Capture again = Capture::open(data_test::tiny_config(root), cache);
  for (int i = 0; i < 4; ++i)
    CHECK(cv::norm(again.decode_image(again.frames()[i]), first[i], cv::NORM_INF) == 0);
}

TEST_CASE("capture layouts: masks supplied with a handscs capture replace the mesh's") {
  const std::string root = data_test::copy_of_tiny_in("handscs", "supplied_masks");
  Capture plain = Capture::open(data_test::tiny_config(root));
  const std::string mask_file = write_supplied_mask(root, plain.frames()[5]);
  Capture capture = Capture::open(data_test::tiny_config(root));
  const FrameInfo& g = capture.frames()[5];
  CHECK(g.mask_path == mask_file);
  CHECK(capture.frames()[4].mask_path.empty());
  const FrameSample sample = capture.load(g);
  CHECK(sample.roi.x0 == 40 - 16);  // the ROI follows the supplied mask (roi_margin 16)
  CHECK(sample.roi.y0 == 60 - 16);
  CHECK(sample.mask.sum().item<int64_t>() == 30 * 40);
}

TEST_CASE("capture layouts: a named pipe in a supplied mask's place, or a masks file, is refused") {
  // Both were passed over for the posed mesh's mask without a word.
  const std::string root = data_test::copy_of_tiny_in("handscs", "supplied_mask_pipe");
  Capture plain = Capture::open(data_test::tiny_config(root));
  const FrameInfo& f = plain.frames()[5];
  const std::string mask_file =
      root + "/masks/" + f.camera_id + "/" + frame_file_stem(f.frame_idx) + ".png";
  std::filesystem::create_directories(std::filesystem::path(mask_file).parent_path());
  REQUIRE(mkfifo(mask_file.c_str(), 0600) == 0);
  Capture capture = Capture::open(data_test::tiny_config(root));
  const FrameInfo& g = capture.frames()[5];
  CHECK(g.mask_path == mask_file);
  CHECK(error_of([&] { capture.load(g); }) ==
        mask_file + ": is not a regular file (a named pipe, a device or a socket); give a file");
  std::filesystem::remove_all(root + "/masks");
  data_test::write_text(root + "/masks", "x");
  CHECK(error_of([&] { Capture::open(data_test::tiny_config(root)); }) ==
        root + "/masks: not a folder; supplied masks go in masks/<camera>/<frame>.png (remove it to "
               "use the posed meshes' masks)");
}

TEST_CASE("capture layouts: a truncated supplied PNG mask is refused by name before libpng sees it") {
  const std::string root = data_test::copy_of_tiny_in("handscs", "supplied_mask_cut");
  Capture plain = Capture::open(data_test::tiny_config(root));
  const std::string mask_file = write_supplied_mask(root, plain.frames()[5], 0.5);
  Capture capture = Capture::open(data_test::tiny_config(root));
  const FrameInfo& g = capture.frames()[5];
  REQUIRE(g.mask_path == mask_file);
  const std::string error = error_of([&] { capture.load(g); });
  CHECK(error.rfind(mask_file + ": damaged PNG mask (truncated: ", 0) == 0);
}

TEST_CASE("capture layouts: a supplied mask the posed hand disagrees with is named once") {
  const std::string root = data_test::copy_of_tiny_in("handscs", "disagreeing_masks");
  CaptureConfig config = data_test::tiny_config(root);
  config.mask_refine.enabled = false;  // the mesh's own mask
  Capture plain = Capture::open(config);
  // Frame 4 gets the mesh's own mask (it agrees), frame 5 a box beside the hand (it does not).
  const auto mask_file = [&](const FrameInfo& f) {
    return root + "/masks/" + f.camera_id + "/" + frame_file_stem(f.frame_idx) + ".png";
  };
  const FrameInfo& agreeing = plain.frames()[4];
  const FrameInfo& wrong = plain.frames()[5];
  const cv::Mat mesh = plain.compute_mask(agreeing, plain.decode_image(agreeing));
  cv::Mat box(wrong.camera.height, wrong.camera.width, CV_8UC1, cv::Scalar(0));
  box(cv::Rect(2, 2, 12, 12)).setTo(255);
  for (const auto& [frame, mask] : {std::pair<const FrameInfo*, cv::Mat>{&agreeing, mesh * 255}, {&wrong, box}}) {
    std::filesystem::create_directories(std::filesystem::path(mask_file(*frame)).parent_path());
    cv::imwrite(mask_file(*frame), mask);
  }
  {
    handscs_test::CapturedWarnings warnings;
    Capture capture = Capture::open(config);
    (void)capture.load(capture.frames()[4]);
    (void)capture.load(capture.frames()[5]);
    (void)capture.load(capture.frames()[5], /*full_image=*/true);  // named once
    const std::string text = warnings.text();
    INFO(text);
    CHECK(text.find(mask_file(agreeing)) == std::string::npos);
    const size_t at = text.find(mask_file(wrong) + ": the mask covers ");
    REQUIRE(at != std::string::npos);
    CHECK(text.find(mask_file(wrong), at + 1) == std::string::npos);
    CHECK(text.find("the mask or the pose is wrong (set data.supplied_masks=replace_poor, or remove the "
                    "mask file") != std::string::npos);
  }
  // replace_poor: the disagreeing mask gives way to the posed mesh's, the agreeing one is kept;
  // ignore: every mask is the posed mesh's.
  const cv::Mat mesh_of_wrong = plain.compute_mask(wrong, plain.decode_image(wrong));
  cv::Mat kept_box;
  cv::threshold(box, kept_box, 127, 1, cv::THRESH_BINARY);
  for (const auto mode : {CaptureConfig::SuppliedMasks::use, CaptureConfig::SuppliedMasks::replace_poor,
                          CaptureConfig::SuppliedMasks::ignore}) {
    INFO(choice_name(mode, CaptureConfig::supplied_masks_names()));
    config.supplied_masks = mode;
    handscs_test::CapturedWarnings warnings;
    Capture capture = Capture::open(config);
    const FrameInfo& f = capture.frames()[5];
    CHECK(f.mask_path.empty() == (mode == CaptureConfig::SuppliedMasks::ignore));
    const FrameSample sample = capture.load(f, /*full_image=*/true);
    const cv::Mat loaded(f.camera.height, f.camera.width, CV_8UC1, sample.mask.data_ptr<uint8_t>());
    const cv::Mat expected = mode == CaptureConfig::SuppliedMasks::use ? kept_box : mesh_of_wrong;
    CHECK(cv::norm(loaded, expected, cv::NORM_INF) == 0);
    const bool warned = warnings.text().find(mask_file(wrong)) != std::string::npos;
    CHECK(warned == (mode != CaptureConfig::SuppliedMasks::ignore));
    if (mode == CaptureConfig::SuppliedMasks::replace_poor)
      CHECK(warnings.text().find("the posed meshes' mask is used instead") != std::string::npos);
  }
}

TEST_CASE("capture layouts: malformed handscs captures are errors naming the file and key") {
  const std::string root = data_test::copy_of_tiny_in("handscs", "bad_handscs");
  const std::string file = root + "/capture.json";
  const json original = parse_json_file(file);
  auto error_with = [&](const std::function<void(json&)>& edit) {
    json value = original;
    edit(value);
    data_test::write_text(file, value.dump());
    return error_of([&] { Capture::open(data_test::tiny_config(root)); });
  };
  CHECK(error_with([](json& c) { c.erase("frames"); }) == file + ": (top level): missing key \"frames\"");
  CHECK(error_with([](json& c) { c["cameras"]["400004"].erase("t"); }) ==
        file + ": cameras.400004: missing key \"t\"");
  CHECK(error_with([](json& c) { c["cameras"]["400004"]["K"].erase(2); }) ==
        file + ": cameras.400004.K: expected 3x3 array, got array of 2");
  CHECK(error_with([](json& c) { c["frames"][3]["right"]["pose"].erase(47); }) ==
        file + ": frames[3].right.pose: expected array of 48, got array of 47");
  CHECK(error_with([](json& c) { c["cameras"]["400004"]["dist"] = {0.1, 0.2, 0.3}; }) ==
        file + ": cameras.400004.dist: expected array of 5 (k1, k2, p1, p2, k3) or 4, got array of 3");
  CHECK(error_with([](json& c) { c["version"] = 2; }) ==
        file + ": version: version 2 is not one this build reads (it reads 1)");
  CHECK(error_with([](json& c) { c["format"] = "interhand"; }) ==
        file + ": format: expected \"handscs-capture\", got \"interhand\"");
  CHECK(error_with([](json& c) { c["frames"][0]["hand"] = "right"; }) ==
        file + ": frames[0]: unknown key \"hand\" (known: frame, sequence, hand_type, right, left)");
  CHECK(error_with([](json& c) { c["frames"][2]["frame"] = 0; }) ==
        file + ": frames[2].frame: frame 0 appears twice");
  CHECK(error_with([](json& c) { c["flat_hand_mean"] = true; }) ==
        file + ": flat_hand_mean: poses are stored with flat_hand_mean true but data.flat_hand_mean "
               "is false (set it to match)");
  CHECK(error_with([](json& c) { c["cameras"]["400004"]["R"][0][0] = 2.0; })
            .rfind(file + ": cameras.400004.R: ", 0) == 0);
  // A key given twice would otherwise be read as its last value, without a word.
  std::string twice = original.dump();
  twice.insert(1, R"("version": 7, )");
  data_test::write_text(file, twice);
  CHECK(error_of([&] { Capture::open(data_test::tiny_config(root)); }) ==
        file + ": version: key given twice (remove one; JSON readers would keep the last)");
  data_test::write_text(file, original.dump());
  std::filesystem::remove_all(root + "/images/400006");
  CHECK(error_of([&] { Capture::open(data_test::tiny_config(root)); }) ==
        root + "/images/400006: missing image folder of camera \"400006\" (cameras.400006 in " + file + ")");
}

TEST_CASE("capture layouts: malformed EasyMocap calibration files are errors naming the file and key") {
  const std::string root = data_test::copy_of_tiny_in("easymocap", "bad_easymocap");
  const std::string intri = root + "/intri.yml", extri = root + "/extri.yml";
  const std::string intri_text = read_file(intri);
  const std::string extri_text = read_file(extri);
  auto replaced = [](std::string text, const std::string& from, const std::string& to) {
    const size_t at = text.find(from);
    REQUIRE(at != std::string::npos);
    return text.replace(at, from.size(), to);
  };
  auto error_with = [&](const std::string& intri_now, const std::string& extri_now) {
    data_test::write_text(intri, intri_now);
    data_test::write_text(extri, extri_now);
    return error_of([&] { Capture::open(data_test::tiny_config(root)); });
  };
  CHECK(error_with(replaced(intri_text, "K_400004:", "Kx_400004:"), extri_text) ==
        intri + ": K_400004: missing key");
  CHECK(error_with(replaced(intri_text, "K_400004: !!opencv-matrix\n   rows: 3\n   cols: 3",
                            "K_400004: !!opencv-matrix\n   rows: 1\n   cols: 9"),
                   extri_text) == intri + ": K_400004: expected a 3x3 matrix, got 1x9");
  {
    // dist_400002 as a 1x3 matrix: the block from its key to the next key replaced.
    std::string text = intri_text;
    const size_t from = text.find("dist_400002:"), to = text.find("H_400002:");
    REQUIRE(from != std::string::npos);
    REQUIRE(to != std::string::npos);
    text.replace(from, to - from,
                 "dist_400002: !!opencv-matrix\n   rows: 1\n   cols: 3\n   dt: d\n   data: [ 0.1, 0.2, 0.3 ]\n");
    CHECK(error_with(text, extri_text) ==
          intri + ": dist_400002: expected 5 or 4 numbers (an n x 1 or 1 x n matrix), got 1x3");
  }
  CHECK(error_with(replaced(intri_text, "H_400004: 256", "H_400004: 0"), extri_text) ==
        intri + ": H_400004: image size 0 is not in [1, 65535] pixels");
  CHECK(error_with(replaced(intri_text, "W_400004: 167", "W_400004: 100000"), extri_text) ==
        intri + ": W_400004: image size 100000 is not in [1, 65535] pixels");
  CHECK(error_with(intri_text, "") == extri + ": is empty (expected OpenCV YAML: \"%YAML:1.0\", then "
                                               "the cameras' keys)");
  CHECK(error_with(replaced(intri_text, "names:", "nomes:"), extri_text) == intri + ": names: missing key");
  std::filesystem::remove(extri);
  CHECK(error_of([&] { Capture::open(data_test::tiny_config(root)); }) ==
        extri + ": missing (the easymocap layout needs it beside " + intri + ")");
}

TEST_CASE("capture layouts: novel_view and sequence selection on a handscs capture") {
  const std::string root = data_test::tiny_capture_in("handscs");
  CaptureConfig config = data_test::tiny_config(root);
  config.split_rule = CaptureConfig::SplitRule::novel_view;
  config.train_cameras = {"400002", "400004", "400006"};
  config.test_cameras = {"400008"};
  Capture capture = Capture::open(config);
  CHECK(capture.train().size() == 3 * 12);
  CHECK(capture.test().size() == 12);
  for (const FrameInfo& f : capture.test()) CHECK(f.camera_id == "400008");
  config = data_test::tiny_config(root);
  config.sequences = {"0000_synth_rom"};
  CHECK(Capture::open(config).frames().size() == 48);
  config.sequences = {"grasp"};
  CHECK(error_of([&] { Capture::open(config); }) ==
        "data.sequences: sequence \"grasp\" has no frames in " + root +
            "/capture.json; it has 0000_synth_rom");
}

TEST_CASE("capture layouts: a left-hand capture reads alike in the InterHand2.6M and handscs layouts") {
  std::map<std::string, std::string> roots;
  for (const char* layout : {"interhand", "handscs"}) {
    roots[layout] = data_test::fresh_dir(std::string("left_") + layout);
    SynthConfig config = synth_preset("tiny");
    config.hand = CaptureConfig::Hands::left;
    config.layout = choice_value(layout, SynthConfig::layout_names());
    write_synth_capture(make_synth_scene(config), roots[layout]);
  }
  CaptureConfig config = data_test::tiny_config(roots["interhand"]);
  config.hand = CaptureConfig::Hands::left;
  Capture reference = Capture::open(config);
  config.root = roots["handscs"];
  Capture capture = Capture::open(config);
  REQUIRE(capture.frames().size() == reference.frames().size());
  for (size_t i = 0; i < capture.frames().size(); ++i) {
    const FrameInfo& f = capture.frames()[i];
    const FrameInfo& r = reference.frames()[i];
    CHECK(f.camera.K == r.camera.K);
    CHECK(f.camera.R == r.camera.R);
    CHECK(f.camera.t == r.camera.t);
    CHECK(f.pose == r.pose);
    CHECK(f.trans == r.trans);
    const cv::Mat image = capture.decode_image(f);
    CHECK(cv::norm(image, reference.decode_image(r), cv::NORM_INF) == 0);
    CHECK(cv::norm(capture.compute_mask(f, image), reference.compute_mask(r, image), cv::NORM_INF) == 0);
  }
}

TEST_CASE("capture layouts: without H_ and W_ an EasyMocap camera takes its first image's size") {
  const std::string root = data_test::copy_of_tiny_in("easymocap", "no_size");
  auto cameras = read_easymocap_cameras(root + "/intri.yml", root + "/extri.yml");
  std::string intri = read_file(root + "/intri.yml");
  for (const auto& [name, record] : cameras)
    for (const std::string& key : {"H_" + name + ": ", "W_" + name + ": "}) {
      const size_t from = intri.find(key);
      REQUIRE(from != std::string::npos);
      intri.erase(from, intri.find('\n', from) + 1 - from);
    }
  data_test::write_text(root + "/intri.yml", intri);
  for (const auto& [name, record] : read_easymocap_cameras(root + "/intri.yml", root + "/extri.yml"))
    CHECK(record.camera.width == 0);
  Capture capture = Capture::open(data_test::tiny_config(root));
  Capture reference = Capture::open(data_test::tiny_config(data_test::tiny_capture_in("easymocap")));
  REQUIRE(capture.frames().size() == reference.frames().size());
  for (size_t i = 0; i < capture.frames().size(); ++i) {
    CHECK(capture.frames()[i].camera.width == reference.frames()[i].camera.width);
    CHECK(capture.frames()[i].camera.height == reference.frames()[i].camera.height);
  }
  // A camera whose first image is a named pipe takes its size from the next one, without waiting
  // on the pipe (opening it for reading would block until something writes to it).
  const std::string first = reference.frames()[0].image_path;
  const std::string piped = root + first.substr(first.find("/images/"));
  std::filesystem::remove(piped);
  REQUIRE(::mkfifo(piped.c_str(), 0600) == 0);
  Capture without_first = Capture::open(data_test::tiny_config(root));
  REQUIRE(without_first.skipped().size() == 1);
  CHECK(without_first.skipped()[0].path == piped);
  CHECK(without_first.skipped()[0].reason == "not a file");
  REQUIRE(without_first.frames().size() == reference.frames().size() - 1);
  for (const FrameInfo& frame : without_first.frames())
    if (frame.camera_id == reference.frames()[0].camera_id) {
      CHECK(frame.camera.width == reference.frames()[0].camera.width);
      CHECK(frame.camera.height == reference.frames()[0].camera.height);
    }
}

TEST_CASE("capture layouts: PNG images of an odd size open in every layout, in all cameras or one") {
  // The tiny capture's 167 x 256 pixels: 167 is no multiple of 8, where OpenCV's 1/8 decode of a PNG
  // (20 px wide) and libjpeg's of a JPEG (21 px) differ.
  for (const char* layout : {"interhand", "handscs", "easymocap"}) {
    INFO(layout);
    const Capture reference = Capture::open(data_test::tiny_config(data_test::tiny_capture_in(layout)));
    REQUIRE(reference.frames().size() == 48);
    REQUIRE(reference.frames()[0].camera.width % 8 != 0);
    const std::string first_camera =
        std::filesystem::path(reference.frames()[0].image_path).parent_path().filename().string();
    for (const bool one_camera : {false, true}) {
      INFO((one_camera ? "PNGs in camera " + first_camera + " only" : "PNGs in every camera"));
      const std::string root = tiny_with_pngs(layout, std::string("png_") + layout + (one_camera ? "_one" : "_all"),
                                              one_camera ? std::set<std::string>{first_camera} : std::set<std::string>{});
      Capture capture = Capture::open(data_test::tiny_config(root));
      CHECK(capture.skip_summary().empty());
      CHECK(capture.skipped().empty());
      CHECK(capture.cameras() == reference.cameras());
      REQUIRE(capture.frames().size() == reference.frames().size());
      const FrameInfo& png = capture.frames()[0];
      CHECK(std::filesystem::path(png.image_path).extension() == ".png");
      CHECK(capture.decode_image(png).cols == png.camera.width);
      if (one_camera) CHECK(std::filesystem::path(capture.frames().back().image_path).extension() == ".jpg");
    }
  }
  // The check is exact: a PNG, or a JPEG, one pixel narrower than its camera is skipped (the JPEG's
  // 1/8 decode has the camera's width in blocks), not refused later when training loads it.
  const std::string root = tiny_with_pngs("handscs", "png_narrow");
  Capture reference = Capture::open(data_test::tiny_config(root));
  const FrameInfo& png = reference.frames()[0];
  const FrameInfo& next = reference.frames()[1];
  const std::string jpeg = std::filesystem::path(next.image_path).replace_extension(".jpg").string();
  const cv::Mat narrow(png.camera.height, png.camera.width - 1, CV_8UC3, cv::Scalar(90, 120, 160));
  REQUIRE(cv::imwrite(png.image_path, narrow));
  std::filesystem::remove(next.image_path);
  REQUIRE(cv::imwrite(jpeg, narrow));
  Capture narrowed = Capture::open(data_test::tiny_config(root));
  REQUIRE(narrowed.skipped().size() == 2);
  CHECK(narrowed.skipped()[0].path == png.image_path);
  CHECK(narrowed.skipped()[0].reason == "wrong image size");
  CHECK(narrowed.skipped()[1].path == jpeg);
  CHECK(narrowed.skipped()[1].reason == "wrong image size");
}
