// The layout NeuS, IDR and FMHR share: the camera archive's world_mat_i against FMHR's own int_i
// and ext_i, FMHR's demo folder opened as a capture with a hands file, and synthetic archives
// (written here) whose bad cameras, images and hands are errors naming the file and the key.
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "captured_warnings.h"
#include "data/capture.h"
#include "data/capture_layout.h"
#include "data/neus_cameras.h"
#include "data/neus_capture.h"
#include "hand/joint_model.h"
#include "hand/keypoint_fit.h"  // absolute_pose
#include "data_test_helpers.h"
#include "io/npz.h"
#include "npz_writer.h"

// Catch last: LibTorch pulls in glog, whose CHECK macro would otherwise replace Catch's.
#include <catch2/catch.hpp>

using namespace handscs;
using data_test::error_of;
using nlohmann::json;
namespace fs = std::filesystem;

namespace {

const std::string kFmhr = std::string(HANDSCS_SHARED_DIR) + "/testdata/fmhr_demo";

// {"frames": [frame 0 with a flat right hand of mean shape at `trans`]} as a hands file.
std::string write_hands(const std::string& path, const std::array<double, 3>& trans, const json& extra = json::object()) {
  json hand = {{"pose", std::vector<double>(48, 0.0)}, {"shape", std::vector<double>(10, 0.0)},
               {"trans", {trans[0], trans[1], trans[2]}}};
  json doc = extra;
  doc["frames"] = json::array({{{"frame", 0}, {"right", hand}}});
  return data_test::write_text(path, doc.dump());
}

// The point nearest every camera's optical axis (least squares): where a studio's cameras look.
std::array<double, 3> where_cameras_look(const std::vector<NeusView>& views) {
  double A[9] = {}, b[3] = {};
  for (const NeusView& v : views) {
    const auto& R = v.camera.R;
    const auto& t = v.camera.t;
    const double d[3] = {R[6], R[7], R[8]};  // the axis: R^T (0, 0, 1)
    double c[3];                              // the centre: -R^T t
    for (int i = 0; i < 3; ++i) c[i] = -(R[i] * t[0] + R[3 + i] * t[1] + R[6 + i] * t[2]);
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        const double m = (i == j ? 1.0 : 0.0) - d[i] * d[j];
        A[3 * i + j] += m;
        b[i] += m * c[j];
      }
  }
  const cv::Matx33d M(A);
  const cv::Vec3d x = M.solve(cv::Vec3d(b[0], b[1], b[2]), cv::DECOMP_LU);
  return {x[0], x[1], x[2]};
}

// 4x4 world_mat = K [R | t] with K = [f 0 cx; 0 f cy; 0 0 1] (OpenCV's pixel centres), R a turn
// by `angle` about y and t = (0, 0, 0.5): the origin lies 0.5 m in front.
data_test::NpzArray world_mat(double f, double cx, double cy, double angle) {
  const double c = std::cos(angle), s = std::sin(angle);
  const double Rt[12] = {c, 0, s, 0, 0, 1, 0, 0, -s, 0, c, 0.5};
  const double K[9] = {f, 0, cx, 0, f, cy, 0, 0, 1};
  data_test::NpzArray out{{4, 4}, std::vector<double>(16, 0.0)};
  for (int r = 0; r < 3; ++r)
    for (int col = 0; col < 4; ++col)
      for (int k = 0; k < 3; ++k) out.values[4 * r + col] += K[3 * r + k] * Rt[4 * k + col];
  out.values[15] = 1.0;
  return out;
}

// A plain colour image, or (grey = 255) a mask marking every pixel as hand.
void write_image(const std::string& path, int width, int height, int grey = -1) {
  fs::create_directories(fs::path(path).parent_path());
  const cv::Scalar colour = grey < 0 ? cv::Scalar(90, 120, 150) : cv::Scalar::all(grey);
  REQUIRE(cv::imwrite(path, cv::Mat(height, width, CV_8UC3, colour)));
}

// A synthetic neus folder: cameras.npz with `views` views (64 x 48 images, f = 60 px), img/NN.png
// and mask/NN.png for each, and hands.json with a flat hand at the origin.
std::string synthetic_neus(const std::string& name, int views = 3) {
  const std::string root = data_test::fresh_dir(name);
  std::map<std::string, data_test::NpzArray> arrays;
  for (int i = 0; i < views; ++i) {
    char stem[16];
    std::snprintf(stem, sizeof(stem), "%02d", i);
    arrays["world_mat_" + std::to_string(i)] = world_mat(60, 31.5, 23.5, 0.3 * i);
    arrays["scale_mat_" + std::to_string(i)] = {{4, 4}, {2, 0, 0, 0, 0, 2, 0, 0, 0, 0, 2, 0, 0, 0, 0, 1}};
    write_image(root + "/img/" + stem + ".png", 64, 48);
    write_image(root + "/mask/" + stem + ".png", 64, 48, 255);
  }
  data_test::write_npz(root + "/cameras.npz", arrays);
  write_hands(root + "/hands.json", {0, 0, 0});
  return root;
}

CaptureConfig neus_config(const std::string& root) {
  CaptureConfig c;
  c.root = root;
  c.hands_file = root + "/hands.json";
  c.split_rule = CaptureConfig::SplitRule::novel_view;
  c.cache.prefetch_threads = 0;
  // The shared test data stays unwritten: the image checks' cache goes to a temporary folder.
  c.scan_cache = data_test::fresh_dir("neus_scans");
  return c;
}

CaptureRecords read_records(const CaptureConfig& c) { return read_neus_capture(c, "data"); }

}  // namespace

TEST_CASE("neus cameras: FMHR's world_mat_i gives its int_i and ext_i, cx and cy half a pixel on") {
  const auto arrays = read_npz(kFmhr + "/camera/param.npz");
  const NeusViews views = read_neus_views(kFmhr);
  CHECK(views.archive == kFmhr + "/camera/param.npz");
  REQUIRE(views.views.size() == 16);
  for (int i = 0; i < 16; ++i) {
    INFO("view " << i);
    const NeusView& view = views.views[i];
    CHECK(view.name == (i < 10 ? "0" : "") + std::to_string(i));
    CHECK(view.where == views.archive + ": world_mat_" + std::to_string(i));
    CHECK(view.image == kFmhr + "/img/" + view.name + ".png");
    CHECK(view.mask == kFmhr + "/mask/" + view.name + ".png");
    CHECK((view.camera.width == 1280 && view.camera.height == 1024));
    const auto& K = arrays.at("int_" + std::to_string(i)).values;
    const auto& E = arrays.at("ext_" + std::to_string(i)).values;
    const double shift[9] = {0, 0, 0.5, 0, 0, 0.5, 0, 0, 0};  // OpenCV's pixel centres -> the project's
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) {
        CHECK(view.camera.K[3 * r + c] == Approx(K[4 * r + c] + shift[3 * r + c]).margin(1e-6 * K[0]));
        CHECK(view.camera.R[3 * r + c] == Approx(E[4 * r + c]).margin(1e-6));
      }
      CHECK(view.camera.t[r] == Approx(E[4 * r + 3]).margin(1e-6 * (1 + std::fabs(E[4 * r + 3]))));
    }
  }
  // Any scale and either sign of the projection give the same camera; a singular block is named.
  const auto& W = arrays.at("world_mat_3").values;
  double P[12];
  for (int e = 0; e < 12; ++e) P[e] = -2.5 * W[e];
  const Camera scaled = camera_from_projection(P, 1280, 1024, "test");
  for (int e = 0; e < 9; ++e) CHECK(scaled.K[e] + (e == 2 || e == 5 ? 0.5 : 0.0) ==
                                  Approx(views.views[3].camera.K[e]).margin(1e-6 * scaled.K[0]));
  const double flat[12] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0};  // rows 2 and 3 equal: singular
  CHECK(error_of([&] { camera_from_projection(flat, 100, 100, "cameras.npz: world_mat_3"); }) ==
        "cameras.npz: world_mat_3: the projection's left 3x3 block is singular: no camera");
}

TEST_CASE("neus layout: FMHR's folder opens as a capture with a hands file") {
  CHECK(detect_capture_layout(kFmhr, CaptureConfig::Layout::automatic) == CaptureConfig::Layout::neus);
  const NeusViews views = read_neus_views(kFmhr);
  const std::string dir = data_test::fresh_dir("neus_fmhr");
  CaptureConfig c = neus_config(kFmhr);
  // capture.json's header and cameras, as handscs-fit --multiview writes them, are accepted.
  c.hands_file = write_hands(dir + "/capture.json", where_cameras_look(views.views),
                             {{"format", "handscs-capture"}, {"version", 1}, {"flat_hand_mean", false},
                              {"cameras", json::object()}});
  c.test_cameras = {"view02", "view09"};
  const Capture capture = Capture::open(c, dir + "/cache");
  CHECK(capture.layout() == CaptureConfig::Layout::neus);
  std::vector<std::string> ids;
  for (int i = 0; i < 16; ++i) ids.push_back((i < 10 ? "view0" : "view") + std::to_string(i));
  CHECK(capture.cameras() == ids);
  CHECK(capture.frames().size() == 16);
  CHECK(capture.train().size() == 14);
  REQUIRE(capture.test().size() == 2);
  CHECK(capture.test()[0].camera_id == "view02");
  CHECK(capture.test()[0].mask_path == kFmhr + "/mask/02.png");
  CHECK(capture.test()[0].camera.K[2] == Approx(views.views[2].camera.K[2]));

  // Without a hands file the error says what to run.
  c.hands_file.clear();
  CHECK(error_of([&] { Capture::open(c, dir + "/cache"); }) ==
        "data.hands_file: not set, and the neus layout of " + kFmhr +
            " has no hand poses: fit them with `handscs-fit --multiview " + kFmhr +
            " --out DIR`, then set data.hands_file=DIR/capture.json");
}

TEST_CASE("neus layout: cameras that are no cameras, images without cameras, bad hands files") {
  const std::string root = synthetic_neus("neus_errors");
  const std::string archive = root + "/cameras.npz";
  REQUIRE(detect_capture_layout(root, CaptureConfig::Layout::automatic) == CaptureConfig::Layout::neus);
  REQUIRE(read_records(neus_config(root)).images.size() == 3);
  auto with_view1 = [&](const data_test::NpzArray& m) {
    std::map<std::string, data_test::NpzArray> arrays;
    for (int i = 0; i < 3; ++i) arrays["world_mat_" + std::to_string(i)] = world_mat(60, 31.5, 23.5, 0.3 * i);
    arrays["world_mat_1"] = m;
    data_test::write_npz(archive, arrays);
  };
  // Rank-deficient: the third row a multiple of the first.
  data_test::NpzArray singular = world_mat(60, 31.5, 23.5, 0.3);
  for (int c = 0; c < 4; ++c) singular.values[8 + c] = 2 * singular.values[c];
  with_view1(singular);
  CHECK(error_of([&] { read_records(neus_config(root)); }) ==
        archive + ": world_mat_1: the projection's left 3x3 block is singular: no camera");
  data_test::NpzArray nan = world_mat(60, 31.5, 23.5, 0.3);
  nan.values[5] = std::nan("");
  with_view1(nan);
  CHECK(error_of([&] { read_records(neus_config(root)); }) == archive + ": world_mat_1: non-finite value");
  // A negative focal length decomposes into a camera turned around: the hand lies behind it.
  data_test::NpzArray negative = world_mat(60, 31.5, 23.5, 0.3);
  for (int c = 0; c < 4; ++c) negative.values[c] = -negative.values[c] + 2 * 31.5 * negative.values[8 + c];
  with_view1(negative);
  CHECK(error_of([&] { read_records(neus_config(root)); }) ==
        archive + ": world_mat_1: frame 0's right hand (trans of " + root +
            "/hands.json) lies behind camera view01 (depth -0.500000): the matrix has a negative focal "
            "length or is not this capture's");
  // A focal length of 2 km is implausible for its image's size.
  with_view1(world_mat(3e5, 31.5, 23.5, 0.3));
  CHECK_THAT(error_of([&] { read_records(neus_config(root)); }),
             Catch::StartsWith(archive + ": world_mat_1 (with the 64x48 size of " + root + "/img/01.png): fx = "));
  with_view1(world_mat(60, 31.5, 23.5, 0.3));
  REQUIRE(read_records(neus_config(root)).images.size() == 3);

  // An image numbered beyond the archive's views.
  write_image(root + "/img/05.png", 64, 48);
  CHECK(error_of([&] { read_records(neus_config(root)); }) ==
        root + "/img/05.png: image of view 5, but " + archive + " has no world_mat_5 (nor int_5 and ext_5)");
  fs::remove(root + "/img/05.png");

  // Hands files: a second instant, another layout's key, flat_hand_mean against the config's.
  CaptureConfig c = neus_config(root);
  json two = parse_json_file(c.hands_file);
  two["frames"].push_back(two["frames"][0]);
  two["frames"][1]["frame"] = 1;
  data_test::write_text(c.hands_file, two.dump());
  CHECK(error_of([&] { read_records(c); }) ==
        c.hands_file + ": frames: frame 1: " + root + " (neus layout) holds one instant, frame 0");
  write_hands(c.hands_file, {0, 0, 0}, {{"flat_hand_mean", true}});
  CHECK(error_of([&] { read_records(c); }) ==
        c.hands_file + ": flat_hand_mean: poses are stored with flat_hand_mean true but data.flat_hand_mean "
                       "is false (set it to match)");
  write_hands(c.hands_file, {0, 0, 0}, {{"camera", 1}});
  CHECK_THAT(error_of([&] { read_records(c); }), Catch::Contains("unknown key \"camera\""));
  c.hands_file = root + "/none.json";
  CHECK(error_of([&] { read_records(c); }) == root + "/none.json: missing or not a file (data.hands_file)");
}

TEST_CASE("neus layout: a hands file whose right hand is the left one is refused, naming the file") {
  const std::string root = synthetic_neus("neus_swapped_hand");
  const CaptureConfig c = neus_config(root);
  // The right entry's joints are those the left hand's rig gives its parameters, as when
  // handscs-fit's two entries are swapped by hand.
  const JointModel left = make_joint_model(load_rig_source("builtin:left"));
  JointParams p;
  p.pose = absolute_pose(left, std::array<double, kPoseDim>{}, c.flat_hand_mean);
  std::array<double, 63> joints{};
  joint_positions(left, p, joints.data());
  json rows = json::array();
  for (int j = 0; j < 21; ++j) rows.push_back({joints[3 * j], joints[3 * j + 1], joints[3 * j + 2]});
  json hands = parse_json_file(c.hands_file);
  hands["frames"][0]["right"]["joints"] = rows;
  data_test::write_text(c.hands_file, hands.dump());
  CHECK_THAT(error_of([&] { Capture::open(c); }),
             Catch::StartsWith(c.hands_file + ": the right hand's MANO parameters fit the left hand's rig far "
                               "better than its own: posed on it they lie 0.0 mm"));
}

TEST_CASE("neus layout: a view without its image is left out, without its mask rasterised, sizes per view") {
  const std::string root = synthetic_neus("neus_gaps", 4);
  fs::remove(root + "/img/02.png");
  fs::remove(root + "/mask/01.png");
  write_image(root + "/img/03.png", 96, 72);
  handscs_test::CapturedWarnings warnings;
  const CaptureRecords records = read_records(neus_config(root));
  CHECK_THAT(warnings.text(), Catch::Contains(root + "/cameras.npz: view 2 has a camera but no image in " + root +
                                              "/img: left out"));
  REQUIRE(records.images.size() == 3);
  CHECK(records.images[0].camera == "view00");
  CHECK(records.images[1].camera == "view01");
  CHECK(records.images[2].camera == "view03");
  CHECK(records.images[0].mask_path == root + "/mask/00.png");
  CHECK(records.images[1].mask_path.empty());  // the posed mesh's mask is rasterised instead
  CHECK((records.images[2].width == 96 && records.images[2].height == 72));
  CHECK(records.cameras.at("view03").camera.width == 96);
  CHECK(records.cameras.at("view00").camera.width == 64);
  CHECK(records.cameras.count("view02") == 0);

  // The neus key on another layout is an error, not ignored.
  CaptureConfig c = neus_config(root);
  c.layout = CaptureConfig::Layout::interhand;
  CHECK_THAT(error_of([&] { Capture::open(c); }),
             Catch::Contains("data.hands_file: only the neus layout reads it (this capture is interhand)"));
}

TEST_CASE("neus layout: one folder per instant shares the root's cameras") {
  const std::string root = synthetic_neus("neus_frames");
  for (const char* frame : {"000000", "000003"}) {
    fs::create_directories(root + "/" + frame);
    fs::copy(root + "/img", root + "/" + frame + "/img");
    fs::copy(root + "/mask", root + "/" + frame + "/mask");
  }
  fs::remove_all(root + "/img");
  fs::remove_all(root + "/mask");
  fs::remove(root + "/000003/mask/02.png");
  CaptureConfig c = neus_config(root);
  json hands = parse_json_file(c.hands_file);
  hands["frames"].push_back(hands["frames"][0]);
  hands["frames"][1]["frame"] = 3;
  hands["frames"][1]["right"]["trans"] = {0.01, 0.0, 0.0};
  data_test::write_text(c.hands_file, hands.dump());

  const CaptureRecords records = read_records(c);
  REQUIRE(records.images.size() == 6);
  CHECK(records.cameras.size() == 3);
  CHECK(records.images[4].file_name == "000003/img/01.png");
  CHECK(records.images[4].frame_idx == 3);
  CHECK(records.images[4].mask_path == root + "/000003/mask/01.png");
  CHECK(records.images[5].mask_path.empty());
  CHECK(records.frames.at(3).right->mano.trans[0] == 0.01);

  c.test_cameras = {"view01"};
  Capture capture = Capture::open(c, data_test::fresh_dir("neus_frames_masks"));
  CHECK(capture.frames().size() == 6);
  CHECK(capture.train().size() == 4);
  CHECK(capture.test().size() == 2);
  // The supplied mask covers the whole image; the rasterised hand, ~20 px across, a part of it.
  for (const FrameInfo& f : capture.frames()) {
    INFO(f.file_name);
    const double covered = capture.load(f, true).mask.to(torch::kFloat).mean().item<double>();
    if (f.file_name == "000003/img/02.png")
      CHECK((covered > 0.02 && covered < 0.5));
    else
      CHECK(covered == 1.0);
  }

  hands["frames"][1]["frame"] = 5;
  data_test::write_text(c.hands_file, hands.dump());
  CHECK(error_of([&] { read_records(c); }) ==
        c.hands_file + ": frames: frame 5: " + root + " (neus layout) has no folder of that frame (<frame>/img/)");
}
