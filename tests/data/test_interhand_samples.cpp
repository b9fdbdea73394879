// The four real InterHand2.6M samples (official schema, read in place from ../shared): parsing,
// camera conversion (every valid joint projects into its annotation bbox) and monochrome detection.
#include <cmath>
#include <filesystem>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "core/config.h"
#include "data/capture.h"
#include "data/image_checks.h"
#include "data/interhand_annotations.h"
#include "data_test_helpers.h"

// Catch last: LibTorch pulls in glog, whose CHECK macro would otherwise replace Catch's.
#include <catch2/catch.hpp>

using namespace handscs;

namespace {
const std::string kData = data_test::samples_dir() + "/test_interhand2.6m_data.json";
const std::string kCamera = data_test::samples_dir() + "/test_interhand2.6m_camera.json";
const std::string kJoints = data_test::samples_dir() + "/test_interhand2.6m_joint_3d.json";
}  // namespace

TEST_CASE("interhand samples: data.json parses with annotations merged") {
  const auto images = read_interhand_images(kData, {});
  REQUIRE(images.size() == 4);
  CHECK(images[0].id == 326750);
  CHECK(images[0].file_name == "image69148.jpg");
  CHECK(images[0].width == 334);
  CHECK(images[0].height == 512);
  CHECK(images[0].capture == 3);
  CHECK(images[0].seq_name == "0390_dh_touchROM");
  CHECK(images[0].camera == "400026");
  CHECK(images[0].frame_idx == 69148);
  CHECK(images[0].hand_type == "interacting");
  CHECK(images[0].bbox[0] == Approx(33.56839370727539));
  CHECK(images[3].width == 512);
  CHECK(images[3].height == 334);
  // image29590 annotates only the left hand: rows 0-20 invalid, 21-41 valid.
  CHECK(images[2].joint_valid[0] == 0);
  CHECK(images[2].joint_valid[20] == 0);
  CHECK(images[2].joint_valid[21] == 1);
  CHECK(images[2].hand_type == "left");

  ImageFilter only_capture_4;
  only_capture_4.capture = 4;
  const auto four = read_interhand_images(kData, only_capture_4);
  REQUIRE(four.size() == 1);
  CHECK(four[0].file_name == "image2017.jpg");
  ImageFilter by_sequence;
  by_sequence.sequences = {"0266_dh_pray"};
  const auto pray = read_interhand_images(kData, by_sequence);
  REQUIRE(pray.size() == 1);
  CHECK(pray[0].id == 286291);
}

TEST_CASE("interhand samples: camera conversion puts every valid joint inside its bbox") {
  const auto images = read_interhand_images(kData, {});
  int checked = 0;
  for (const auto& image : images) {
    const auto cameras = read_interhand_cameras(kCamera, image.capture);
    const auto joints = read_interhand_joints(kJoints, image.capture);
    REQUIRE(cameras.count(image.camera));
    REQUIRE(joints.count(image.frame_idx));
    const InterHandCamera& raw = cameras.at(image.camera);
    const Camera camera = camera_from_interhand(raw, image.width, image.height);
    CHECK(camera.width == image.width);
    // Camera centre recovers campos (mm -> m).
    const auto centre = camera.centre();
    for (int d = 0; d < 3; ++d) CHECK(centre[d] == Approx(raw.campos_mm[d] * 1e-3).margin(1e-9));
    const InterHandJoints& frame = joints.at(image.frame_idx);
    // A few pixels of slack: the bbox is drawn from the 2D annotation, not the 3D joints.
    const double slack = 5.0;
    for (int j = 0; j < kInterHandJoints; ++j) {
      if (!image.joint_valid[j] || !frame.valid[j]) continue;
      const std::array<double, 3> world = {frame.world_mm[j * 3] * 1e-3,
                                           frame.world_mm[j * 3 + 1] * 1e-3,
                                           frame.world_mm[j * 3 + 2] * 1e-3};
      const auto cam = camera.to_camera(world);
      CHECK(cam[2] > 0.9);
      CHECK(cam[2] < 1.3);
      const auto uv = camera.project_camera(cam);
      INFO(image.file_name << " joint " << j << " at " << uv[0] << ", " << uv[1]);
      CHECK(uv[0] >= image.bbox[0] - slack);
      CHECK(uv[0] <= image.bbox[0] + image.bbox[2] + slack);
      CHECK(uv[1] >= image.bbox[1] - slack);
      CHECK(uv[1] <= image.bbox[1] + image.bbox[3] + slack);
      ++checked;
    }
  }
  CHECK(checked == 42 + 42 + 21 + 21);  // two interacting frames, one left, one right
}

TEST_CASE("interhand samples: joint_3d flags and hand types") {
  const auto joints = read_interhand_joints(kJoints, 7);
  REQUIRE(joints.size() == 1);
  const auto& frame = joints.at(29590);
  CHECK(frame.hand_type == "left");
  CHECK(frame.hand_type_valid);
  CHECK(frame.valid[0] == 0);
  CHECK(frame.valid[41] == 1);
  CHECK(frame.world_mm[21 * 3 + 2] == Approx(957.885986328125));
}

TEST_CASE("interhand samples: monochrome cameras are detected") {
  struct Expect {
    const char* file;
    bool mono;
  };
  for (const Expect& e : {Expect{"image69148.jpg", false}, Expect{"image44669.jpg", false},
                          Expect{"image29590.jpg", true}, Expect{"image2017.jpg", true}}) {
    const std::string path = data_test::samples_dir() + "/" + e.file;
    const ImageScan scan = scan_image(path);
    INFO(e.file);
    CHECK(scan.readable);
    CHECK_FALSE(scan.black);
    CHECK(scan.monochrome == e.mono);
    CHECK(is_monochrome(cv::imread(path)) == e.mono);  // full resolution agrees
  }
  const ImageScan missing = scan_image(data_test::samples_dir() + "/no_such_image.jpg");
  CHECK_FALSE(missing.readable);
  cv::Mat black(40, 30, CV_8UC3, cv::Scalar(3, 2, 4));
  CHECK(is_black(black));
  black.at<cv::Vec3b>(5, 5) = cv::Vec3b(0, 0, 200);
  CHECK_FALSE(is_black(black));
}

TEST_CASE("interhand samples: the official schema goes through Capture::open") {
  // Lay the right-hand sample (capture 4) out as the dataset does; no MANO fit exists for it, so a
  // MANO file with a null entry makes the frame skipped, and the capture has nothing left.
  namespace fs = std::filesystem;
  const std::string root = data_test::fresh_dir("real_layout");
  nlohmann::json data = parse_json_file(kData);
  nlohmann::json images = nlohmann::json::array(), annotations = nlohmann::json::array();
  for (size_t i = 0; i < data["images"].size(); ++i) {
    nlohmann::json image = data["images"][i];
    if (image["capture"] != 4) continue;
    const std::string file = "Capture4/" + image["seq_name"].get<std::string>() + "/cam" +
                             image["camera"].get<std::string>() + "/" +
                             image["file_name"].get<std::string>();
    fs::create_directories(fs::path(root + "/images/test/" + file).parent_path());
    fs::copy_file(data_test::samples_dir() + "/" + image["file_name"].get<std::string>(),
                  root + "/images/test/" + file);
    image["file_name"] = file;
    images.push_back(image);
    annotations.push_back(data["annotations"][i]);
  }
  const std::string annotations_dir = root + "/annotations/test/InterHand2.6M_test_";
  data_test::write_text(annotations_dir + "data.json",
                        nlohmann::json{{"images", images}, {"annotations", annotations}}.dump());
  fs::copy_file(kCamera, annotations_dir + "camera.json");
  fs::copy_file(kJoints, annotations_dir + "joint_3d.json");
  data_test::write_text(annotations_dir + "MANO_NeuralAnnot.json",
                        R"({"4": {"2017": {"right": null, "left": null}}})");
  CaptureConfig config;
  config.root = root;
  config.capture = 4;
  const std::string path =
      root + "/images/test/Capture4/0007_thumbup_normal/cam410028/image2017.jpg";
  CHECK(data_test::error_of([&] { Capture::open(config); }) ==
        annotations_dir + "data.json: no usable images in capture 4 (1 considered; " +
            annotations_dir + "data.json: skipped 1 of 1 images (null MANO 1): " + path + ")");
}
