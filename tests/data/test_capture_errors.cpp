// Bad captures: a camera listed but absent, null MANO entries / missing / black images (skipped
// with one summary line), monochrome cameras, bad camera lists, too many held-out poses, missing
// files.
#include <sys/stat.h>

#include <filesystem>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "core/atomic_file.h"
#include "core/config.h"
#include "core/image_header.h"
#include "captured_warnings.h"
#include "data_test_helpers.h"
#include "synth_fixture.h"

// Catch last: LibTorch pulls in glog, whose CHECK macro would otherwise replace Catch's.
#include <catch2/catch.hpp>

using namespace handscs;
using data_test::error_of;
using nlohmann::json;

namespace {

std::string annotation(const std::string& root, const std::string& kind) {
  return root + "/annotations/test/InterHand2.6M_test_" + kind + ".json";
}

void rewrite(const std::string& path, const std::function<void(json&)>& edit) {
  json value = parse_json_file(path);
  edit(value);
  data_test::write_text(path, value.dump());
}

std::string image_path(const std::string& root, const std::string& camera, int64_t frame) {
  return root + "/images/test/Capture0/0000_synth_rom/cam" + camera + "/image" +
         std::to_string(frame) + ".jpg";
}

}  // namespace

TEST_CASE("capture errors: a camera listed in data.json but absent from camera.json") {
  const std::string root = data_test::copy_of_tiny("absent_camera");
  rewrite(annotation(root, "camera"), [](json& c) { c["0"]["campos"].erase("400004"); });
  CHECK(error_of([&] { Capture::open(data_test::tiny_config(root)); }) ==
        annotation(root, "camera") + ": 0.campos: missing key \"400004\" (camera of " +
            "Capture0/0000_synth_rom/cam400004/image0.jpg in " + annotation(root, "data") + ")");
  // Present in campos but not in focal: named by the camera reader.
  const std::string root2 = data_test::copy_of_tiny("absent_focal");
  rewrite(annotation(root2, "camera"), [](json& c) { c["0"]["focal"].erase("400006"); });
  CHECK(error_of([&] { Capture::open(data_test::tiny_config(root2)); }) ==
        annotation(root2, "camera") + ": 0.focal: missing key \"400006\"");
}

TEST_CASE("capture errors: null MANO, missing and black images are skipped with one summary line") {
  const std::string root = data_test::copy_of_tiny("skips");
  const auto& scene = data_test::tiny_capture().scene;
  const int64_t null_frame = scene.frames[4].frame_idx;
  rewrite(annotation(root, "MANO_NeuralAnnot"),
          [&](json& m) { m["0"][std::to_string(null_frame)]["right"] = nullptr; });
  const std::string missing = image_path(root, "400002", scene.frames[7].frame_idx);
  std::filesystem::remove(missing);
  const std::string black = image_path(root, "400006", scene.frames[1].frame_idx);
  const cv::Mat original = cv::imread(black);
  cv::imwrite(black, cv::Mat(original.rows, original.cols, CV_8UC3, cv::Scalar(0, 0, 0)));
  Capture capture = Capture::open(data_test::tiny_config(root));
  CHECK(capture.frames().size() == 48 - 6);
  REQUIRE(capture.skipped().size() == 6);
  const std::string images = root + "/images/test/";
  std::vector<std::string> null_paths;
  for (const char* id : {"400002", "400004", "400006", "400008"})
    null_paths.push_back(image_path(root, id, null_frame));
  // Summary: counts by reason, then the first five paths in data.json order.
  const std::string expected =
      annotation(root, "data") +
      ": skipped 6 of 48 images (null MANO 4, missing image 1, black image 1): " + null_paths[0] +
      ", " + null_paths[1] + ", " + null_paths[2] + ", " + null_paths[3] + ", " + missing + ", ...";
  CHECK(capture.skip_summary() == expected);
  CHECK(capture.skipped()[4].reason == "missing image");
  CHECK(capture.skipped()[5].path == black);
  CHECK(capture.skipped()[5].reason == "black image");
  // An image whose size differs from data.json's, and an undecodable one, are skipped too.
  const std::string small = image_path(root, "400008", scene.frames[2].frame_idx);
  cv::imwrite(small, cv::Mat(100, 80, CV_8UC3, cv::Scalar(90, 120, 160)));
  const std::string corrupt = image_path(root, "400008", scene.frames[3].frame_idx);
  data_test::write_text(corrupt, "not a jpeg");
  Capture more = Capture::open(data_test::tiny_config(root));
  CHECK(more.frames().size() == 48 - 8);
  CHECK(more.skip_summary().rfind(
            annotation(root, "data") +
                ": skipped 8 of 48 images (null MANO 4, missing image 1, damaged JPEG "
                "1, wrong image size 1, black image 1): ",
            0) == 0);
  // With black-image skipping off, the black frame is used.
  CaptureConfig keep_black = data_test::tiny_config(root);
  keep_black.skip_black_images = false;
  CHECK(Capture::open(keep_black).frames().size() == 48 - 7);
}

TEST_CASE("capture errors: an image that is a link to itself is skipped, a looping root is named") {
  const std::string root = data_test::copy_of_tiny("link_loop");
  const auto& scene = data_test::tiny_capture().scene;
  const std::string looped = image_path(root, "400004", scene.frames[2].frame_idx);
  std::filesystem::remove(looped);
  std::filesystem::create_symlink(std::filesystem::path(looped).filename(), looped);
  // std::filesystem's throwing status() aborted the whole capture ("Too many levels of symbolic
  // links"); a missing image is only skipped, and so is this one.
  Capture capture = Capture::open(data_test::tiny_config(root));
  CHECK(capture.frames().size() == 48 - 1);
  REQUIRE(capture.skipped().size() == 1);
  CHECK(capture.skipped()[0].path == looped);
  CHECK(capture.skipped()[0].reason == "unreadable image");
  const std::string loop_root = root + "_loop";
  std::filesystem::remove_all(loop_root);
  std::filesystem::create_symlink(loop_root, loop_root);
  CHECK(error_of([&] { Capture::open(data_test::tiny_config(loop_root)); }) ==
        loop_root + ": capture root is not a folder (Too many levels of symbolic links)");
  std::filesystem::remove(loop_root);
}

TEST_CASE("capture errors: an image whose header claims 30000 x 30000 is skipped with its size") {
  // A decoder would allocate gigabytes for it: the size is read from the header and named instead.
  const std::string root = data_test::copy_of_tiny("oversized_header");
  const auto& scene = data_test::tiny_capture().scene;
  const std::string big = image_path(root, "400004", scene.frames[2].frame_idx);
  std::string bytes = read_file(big);
  const size_t frame_header = bytes.find("\xFF\xC0");  // baseline: length, precision, height, width
  REQUIRE(frame_header != std::string::npos);
  for (const size_t at : {frame_header + 5, frame_header + 7}) {
    bytes[at] = static_cast<char>(30000 >> 8);
    bytes[at + 1] = static_cast<char>(30000 & 0xFF);
  }
  REQUIRE(image_header_size(bytes).width == 30000);
  REQUIRE(image_header_size(bytes).height == 30000);
  data_test::write_text(big, bytes);
  handscs_test::CapturedWarnings warnings;
  Capture capture = Capture::open(data_test::tiny_config(root));
  REQUIRE(capture.skipped().size() == 1);
  CHECK(capture.skipped()[0].path == big);
  CHECK(capture.skipped()[0].reason == "oversized image");
  CHECK(capture.skip_summary() ==
        annotation(root, "data") + ": skipped 1 of 48 images (oversized image 1): " + big);
  CHECK(warnings.text().find(big + ": its header says 30000 x 30000 pixels (900 megapixels), above the "
                                   "100-megapixel limit of a camera: skipped\n") != std::string::npos);
}

TEST_CASE("capture errors: an image replaced by a named pipe after the open is refused, not read") {
  const std::string root = data_test::copy_of_tiny("fifo_later");
  Capture capture = Capture::open(data_test::tiny_config(root));
  const FrameInfo& frame = capture.frames().front();
  std::filesystem::remove(frame.image_path);
  REQUIRE(mkfifo(frame.image_path.c_str(), 0644) == 0);
  // OpenCV would open the pipe and wait for a writer forever.
  CHECK(error_of([&] { capture.decode_image(frame); }) ==
        frame.image_path + ": is not a regular file (a named pipe, a device or a socket); give a file");
}

TEST_CASE("capture errors: frames whose hand is outside the view are skipped") {
  const std::string root = data_test::copy_of_tiny("outside");
  // Turn camera 400004 around (180 degrees about its y axis): the hand is behind it.
  rewrite(annotation(root, "camera"), [](json& c) {
    json& r = c["0"]["camrot"]["400004"];
    for (int k = 0; k < 3; ++k) {
      r[0][k] = -r[0][k].get<double>();
      r[2][k] = -r[2][k].get<double>();
    }
  });
  Capture capture = Capture::open(data_test::tiny_config(root));
  CHECK(capture.frames().size() == 36);
  CHECK(capture.skip_summary().rfind(annotation(root, "data") +
                                         ": skipped 12 of 48 images (hand outside image 12): " +
                                         image_path(root, "400004", 0),
                                     0) == 0);
}

TEST_CASE("capture errors: implausible camera intrinsics and MANO values are errors naming them") {
  const std::string root = data_test::copy_of_tiny("implausible");
  rewrite(annotation(root, "camera"), [](json& c) { c["0"]["focal"]["400004"][0] = 1e-30; });
  const std::string camera_error = error_of([&] { Capture::open(data_test::tiny_config(root)); });
  INFO(camera_error);
  CHECK(camera_error.rfind(annotation(root, "camera") + ": 0: camera 400004 (with the ", 0) == 0);
  CHECK(camera_error.find("): fx = 1e-30 is ") != std::string::npos);
  rewrite(annotation(root, "camera"), [](json& c) { c["0"]["focal"]["400004"][0] = 1000.0; });
  const int64_t frame = data_test::tiny_capture().scene.frames[2].frame_idx;
  rewrite(annotation(root, "MANO_NeuralAnnot"),
          [&](json& m) { m["0"][std::to_string(frame)]["right"]["shape"][0] = 1e6; });
  CHECK(error_of([&] { Capture::open(data_test::tiny_config(root)); }) ==
        annotation(root, "MANO_NeuralAnnot") + ": 0." + std::to_string(frame) +
            ".right: shape[0] = 1e+06 is beyond +-10 standard deviations: not a hand");
}

TEST_CASE("capture errors: monochrome cameras are detected and dropped") {
  const std::string root = data_test::copy_of_tiny("monochrome");
  for (const auto& frame : data_test::tiny_capture().scene.frames) {
    const std::string path = image_path(root, "400008", frame.frame_idx);
    cv::Mat grey = cv::imread(path, cv::IMREAD_GRAYSCALE), bgr;
    cv::cvtColor(grey, bgr, cv::COLOR_GRAY2BGR);
    cv::imwrite(path, bgr);
  }
  CaptureConfig config = data_test::tiny_config(root);
  Capture dropped = Capture::open(config);
  CHECK(dropped.monochrome_cameras() == std::vector<std::string>{"400008"});
  CHECK(dropped.frames().size() == 36);
  for (const auto& f : dropped.frames()) CHECK(f.camera_id != "400008");
  config.drop_monochrome = false;
  Capture kept = Capture::open(config);
  CHECK(kept.monochrome_cameras() == std::vector<std::string>{"400008"});
  CHECK(kept.frames().size() == 48);
  // The grey images of a monochrome camera are that camera's, not grey images in a colour camera.
  CHECK(kept.grey_images().empty());
  // Held out as validation it would leave its validation images dropped: refused while dropped,
  // the test set while kept.
  config.split_rule = CaptureConfig::SplitRule::novel_view;
  config.train_cameras = {"400002", "400004", "400008"};
  config.test_cameras = {"400006"};
  config.validation_cameras = {"400008"};
  Capture validation = Capture::open(config);
  CHECK(validation.test().size() == 12);
  for (const auto& f : validation.test()) CHECK(f.camera_id == "400008");
  config.drop_monochrome = true;
  CHECK(error_of([&] { Capture::open(config); }) ==
        "data.validation_cameras: camera \"400008\" is monochrome and its images are dropped "
        "(data.drop_monochrome); hold out a colour camera");
}

TEST_CASE("capture errors: a grey image in a colour camera is used and named") {
  const std::string root = data_test::copy_of_tiny("grey_image");
  const std::string path = image_path(root, "400004", data_test::tiny_capture().scene.frames[2].frame_idx);
  cv::Mat grey = cv::imread(path, cv::IMREAD_GRAYSCALE), bgr;
  cv::cvtColor(grey, bgr, cv::COLOR_GRAY2BGR);
  cv::imwrite(path, bgr);
  Capture capture = Capture::open(data_test::tiny_config(root));
  CHECK(capture.monochrome_cameras().empty());
  CHECK(capture.frames().size() == 48);
  CHECK(capture.grey_images() == std::vector<std::string>{path});
  CHECK(Capture::open(data_test::tiny_config(data_test::copy_of_tiny("colour_only"))).grey_images().empty());
}

TEST_CASE("capture errors: bad configuration values name the key") {
  const std::string root = data_test::tiny_capture().root;
  const std::string data = annotation(root, "data");
  CaptureConfig config = data_test::tiny_config(root);
  config.train_cameras = {"400002", "499999"};
  CHECK(error_of([&] { Capture::open(config); }) ==
        "data.train_cameras: camera \"499999\" has no images in capture 0 of " + data);

  config = data_test::tiny_config(root);
  config.held_out_poses = 12;
  CHECK(error_of([&] { Capture::open(config); }) ==
        "data.held_out_poses: 12 held-out poses leave nothing to train on (the selection has 12 "
        "poses)");

  config = data_test::tiny_config(root);
  config.train_poses = 10;
  CHECK(error_of([&] { Capture::open(config); }) ==
        "data.train_poses: 10 training poses asked for; the selection has 9 before its 3 "
        "held-out poses");
  config.train_poses = 8;
  config.validation_poses = 2;
  CHECK(error_of([&] { Capture::open(config); }) ==
        "data.train_poses: 8 training poses asked for; the selection has 7 before its 2 "
        "validation poses");
  config.train_poses = 0;
  config.validation_poses = 9;
  CHECK(error_of([&] { Capture::open(config); }) ==
        "data.validation_poses: 9 validation poses leave nothing to train on (the selection has "
        "9 poses before its 3 held-out ones)");
  config.validation_poses = 0;
  config.train_poses = 10;
  config.split_rule = CaptureConfig::SplitRule::novel_view;
  CHECK(error_of([&] { Capture::open(config); }) ==
        "data.train_poses: only split_rule novel_pose selects poses (it is 10 with novel_view)");

  config = data_test::tiny_config(root);
  config.split_rule = CaptureConfig::SplitRule::novel_view;
  config.train_cameras = {"400002"};
  CHECK(error_of([&] { Capture::open(config); }) ==
        "data.test_cameras: split_rule novel_view with train_cameras needs a list of test "
        "cameras");
  config.test_cameras = {"400002"};
  config.train_cameras = {"400002", "400004"};
  CHECK(error_of([&] { Capture::open(config); }) ==
        "data.test_cameras: camera \"400002\" is also a training camera (novel_view needs "
        "disjoint lists)");
  config.train_cameras = {"400004"};
  config.validation_cameras = {"400002"};
  CHECK(error_of([&] { Capture::open(config); }) ==
        "data.validation_cameras: camera \"400002\" is not a training camera (the training "
        "cameras: 400004)");
  config.validation_cameras = {"400004"};
  CHECK(error_of([&] { Capture::open(config); }) ==
        "data.validation_cameras: holds out every training camera (1): none is left to train on");
  config.split_rule = CaptureConfig::SplitRule::novel_pose;
  CHECK(error_of([&] { Capture::open(config); }) ==
        "data.validation_cameras: only split_rule novel_view holds out cameras (it is novel_pose; "
        "novel_pose holds out poses: data.validation_poses)");

  config = data_test::tiny_config(root);
  config.sequences = {"9999_nothing"};
  CHECK(error_of([&] { Capture::open(config); }) ==
        "data.sequences: sequence \"9999_nothing\" has no images in capture 0 of " + data +
            "; it has 0000_synth_rom");

  config = data_test::tiny_config(root);
  config.capture = 5;
  CHECK(error_of([&] { Capture::open(config); }) ==
        data + ": no images of capture 5 (data.capture); the file holds captures 0");

  config = data_test::tiny_config(root);
  config.hand = CaptureConfig::Hands::left;  // the tiny capture annotates only the right hand
  const std::string message = error_of([&] { Capture::open(config); });
  CHECK(message.rfind(data + ": no usable images in capture 0 (48 considered; " + data +
                          ": skipped 48 of 48 images (null MANO 48): ",
                      0) == 0);
}

TEST_CASE("capture errors: missing folders and annotation files") {
  CaptureConfig config;
  config.root = "/nonexistent/handscs_capture";
  CHECK(error_of([&] { Capture::open(config); }) ==
        "/nonexistent/handscs_capture: capture root is not a folder");
  config.root = "";
  CHECK(error_of([&] { Capture::open(config); }) ==
        "data.root: empty (set it to the dataset folder)");

  const std::string empty = data_test::fresh_dir("empty_root");
  config.root = empty;
  CHECK(error_of([&] { Capture::open(config); }) ==
        empty + ": no images/test/ folder (nor InterHand2.6M_5fps_batch1/images/test/)");

  const std::string root = data_test::copy_of_tiny("no_mano");
  std::filesystem::remove(annotation(root, "MANO_NeuralAnnot"));
  CHECK(error_of([&] { Capture::open(data_test::tiny_config(root)); }) ==
        annotation(root, "MANO_NeuralAnnot") + ": cannot open file");

  // The 5 fps release's image folder is found under InterHand2.6M_5fps_batch1/.
  const std::string batch = data_test::copy_of_tiny("batch_layout");
  std::filesystem::create_directories(batch + "/InterHand2.6M_5fps_batch1");
  std::filesystem::rename(batch + "/images", batch + "/InterHand2.6M_5fps_batch1/images");
  CHECK(Capture::open(data_test::tiny_config(batch)).frames().size() == 48);
}

TEST_CASE("capture errors: builtin+fingers is refused on a synthetic capture, whose betas 7-9 were never shown") {
  const std::string root = data_test::tiny_capture().root;
  auto config = data_test::tiny_config(root);
  config.rig = "builtin+fingers";
  CHECK(error_of([&] { Capture::open(config); }) ==
        "data.rig: builtin+fingers reads shape betas 7-9, which a synthetic capture (" + root +
            "/synth.json marks one) fills with values its images never showed; use builtin");
}
