// handscs-fit on keypoint files: a round trip through the file (order and units as written), and
// every bad input named: units, order, missing points, a swapped hand, an occupied output folder.
#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>
#include <random>

#include <nlohmann/json.hpp>

#include "fit/fit_command.h"
#include "hand/keypoint_order.h"
#include "hand/lbs_one_pose.h"
#include "hand/procedural_hand.h"
#include "hand/rig.h"
#include "test_support.h"

using namespace handscs;
using nlohmann::json;
namespace fs = std::filesystem;

namespace {

// Joints of the built-in hand at its mean pose bent a little further, per side, moved by `shift`.
std::array<double, 63> posed_joints(Handedness side, double bend, double shift) {
  const JointModel model = make_joint_model(make_procedural_hand(side));
  JointParams p;
  for (int k = 1; k < kRigJoints; ++k)
    for (int i = 0; i < 3; ++i) p.pose[3 * k + i] = (1.0 + bend) * model.hands_mean[3 * (k - 1) + i];
  p.pose[2] = 0.5;
  p.trans = {shift, 0.05, 0.9};
  std::array<double, 63> x;
  joint_positions(model, p, x.data());
  return x;
}

// The MANO21 joints written in `order`, scaled by `scale`, as a file's hand entry.
json hand_entry(const std::array<double, 63>& mano21, KeypointOrder order, double scale) {
  const auto index = mano21_from_order(order);
  std::vector<json> rows(21);
  for (int j = 0; j < 21; ++j)
    rows[index[j]] = json::array({mano21[3 * j] * scale, mano21[3 * j + 1] * scale, mano21[3 * j + 2] * scale});
  return rows;
}

std::string write_keypoints(const std::string& name, const json& doc) {
  return handscs_test::scratch_file("fit_command", name, doc.dump());
}

FitCommandOptions options_for(const std::string& keypoints, const std::string& out_name) {
  FitCommandOptions o;
  o.keypoints = keypoints;
  o.out = handscs_test::scratch_path("fit_command", out_name);
  fs::remove_all(o.out);
  return o;
}

}  // namespace

TEST_CASE("handscs-fit: keypoints in MediaPipe order and millimetres come back through the POSES file") {
  const auto right = posed_joints(Handedness::right, 0.5, -0.1);
  const auto left = posed_joints(Handedness::left, 0.2, 0.1);
  json frames = json::array();
  for (int f = 0; f < 3; ++f)
    frames.push_back({{"name", "f" + std::to_string(f)},
                      {"right", hand_entry(right, KeypointOrder::mediapipe, 1000.0)},
                      {"left", f == 1 ? json(nullptr) : hand_entry(left, KeypointOrder::mediapipe, 1000.0)}});
  const json doc = {{"format", "handscs-keypoints"}, {"order", "mediapipe"}, {"units", "mm"}, {"frames", frames}};
  FitCommandOptions o = options_for(write_keypoints("mm.json", doc), "roundtrip");
  run_fit_command(o);
  for (const auto& [side, joints, count] :
       {std::tuple{"right", right, 3}, std::tuple{"left", left, 2}}) {
    std::ifstream in(o.out + "/poses_" + side + ".json");
    const json poses = json::parse(in)["poses"];
    REQUIRE(static_cast<int>(poses.size()) == count);
    const Rig rig = make_procedural_hand(std::string(side) == "right" ? Handedness::right : Handedness::left);
    auto tensor = [](const json& values) { return torch::tensor(values.get<std::vector<double>>(), torch::kFloat64); };
    const LbsOutput out = lbs_one_pose(rig, tensor(poses[0]["pose"]), tensor(poses[0]["shape"]),
                                       tensor(poses[0]["trans"]), LbsOptions{false});
    const auto got = out.joints.reshape({63}).contiguous();
    double worst = 0;
    for (int i = 0; i < 63; ++i) worst = std::max(worst, std::fabs(got[i].item<double>() - joints[i]));
    INFO(side);
    CHECK(worst < 1e-3);
  }
  std::ifstream report_in(o.out + "/report.json");
  const json report = json::parse(report_in);
  CHECK(report["hands"]["right"]["fitted"] == 3);
  CHECK(report["hands"]["right"]["mean_mm"].get<double>() < 0.5);
  // The folder now holds a fit: a second run does not replace it unless asked.
  CHECK(handscs_test::error_of([&] { run_fit_command(o); }) ==
        o.out + ": not empty; pass --overwrite to replace the fit in it, or name a new folder");
  o.overwrite = true;
  run_fit_command(o);
  CHECK_FALSE(fs::exists(fs::path(o.out).parent_path() / ("." + fs::path(o.out).filename().string() + ".partial")));
  // --overwrite replaces only a folder handscs-fit wrote: a training run's folder is kept whole.
  FitCommandOptions into_run = o;
  into_run.out = handscs_test::scratch_path("fit_command", "a_run");
  fs::remove_all(into_run.out);
  fs::create_directories(into_run.out);
  const std::string config = into_run.out + "/config.json";
  std::ofstream(config) << "{}";
  CHECK(handscs_test::error_of([&] { run_fit_command(into_run); }) ==
        into_run.out + ": holds no fit (no fit_config.json); --overwrite replaces only a folder handscs-fit wrote: "
                       "name a new folder");
  CHECK(fs::exists(config));
  // A run that fails (here: its input is missing) leaves the earlier fit as it was.
  const auto before = handscs_test::snapshot(o.out);
  FitCommandOptions failing = o;
  failing.keypoints = "/nonexistent/keypoints.json";
  CHECK_FALSE(handscs_test::error_of([&] { run_fit_command(failing); }).empty());
  CHECK(handscs_test::snapshot(o.out) == before);
}

TEST_CASE("handscs-fit: bad keypoint files are refused with the file and key named") {
  const auto right = posed_joints(Handedness::right, 0.3, 0.0);
  auto doc_with = [&](const std::string& order, const std::string& units, double scale) {
    return json{{"format", "handscs-keypoints"}, {"order", order}, {"units", units},
                {"frames", json::array({{{"name", "a"}, {"right", hand_entry(right, KeypointOrder::mano21, scale)}}})}};
  };
  // Millimetres declared as metres.
  std::string path = write_keypoints("units.json", doc_with("mano21", "m", 1000.0));
  CHECK_THAT(handscs_test::error_of([&] { run_fit_command(options_for(path, "units")); }),
             Catch::Contains(path + ": frames[0].right: the hand's median bone is") &&
                 Catch::Contains("look like millimetres (set \"units\": \"mm\")"));
  // No order: never guessed.
  json no_order = doc_with("mano21", "m", 1.0);
  no_order.erase("order");
  path = write_keypoints("order.json", no_order);
  CHECK_THAT(handscs_test::error_of([&] { run_fit_command(options_for(path, "order")); }),
             Catch::Contains(path + ": order: missing"));
  path = write_keypoints("coco.json", doc_with("coco", "m", 1.0));
  CHECK_THAT(handscs_test::error_of([&] { run_fit_command(options_for(path, "coco")); }),
             Catch::Contains("unknown keypoint order \"coco\""));
  // A malformed point.
  json bad_point = doc_with("mano21", "m", 1.0);
  bad_point["frames"][0]["right"][4] = json::array({1, 2});
  path = write_keypoints("point.json", bad_point);
  CHECK_THAT(handscs_test::error_of([&] { run_fit_command(options_for(path, "point")); }),
             Catch::Contains(path + ": frames[0].right[4]: expected [x, y, z] or null"));
  // One wild coordinate: named with the point, not fitted to an infinite residual.
  json wild = doc_with("mano21", "m", 1.0);
  wild["frames"][0]["right"][2][0] = 1e300;
  path = write_keypoints("wild.json", wild);
  CHECK(handscs_test::error_of([&] { run_fit_command(options_for(path, "wild")); }) ==
        path + ": frames[0].right[2][0]: 1e+300 m from the origin: no keypoint of a hand lies beyond 1e+06 m");
  // Two frames of one name (they key the POSES frames and the report's rows), and a name that is
  // not a string (it was replaced by "frame_0" without a word).
  json twice = doc_with("mano21", "m", 1.0);
  twice["frames"].push_back(twice["frames"][0]);
  path = write_keypoints("twice.json", twice);
  CHECK(handscs_test::error_of([&] { run_fit_command(options_for(path, "twice")); }) ==
        path + ": frames[1].name: \"a\" is also frames[0]'s name; each frame needs its own");
  json numbered = doc_with("mano21", "m", 1.0);
  numbered["frames"][0]["name"] = 42;
  path = write_keypoints("numbered.json", numbered);
  CHECK(handscs_test::error_of([&] { run_fit_command(options_for(path, "numbered")); }) ==
        path + ": frames[0].name: expected a string, got number");
  // A left hand's keypoints given as the right hand.
  json swapped = {{"format", "handscs-keypoints"}, {"order", "mano21"}, {"units", "m"},
                  {"frames", json::array({{{"name", "a"},
                                           {"right", hand_entry(posed_joints(Handedness::left, 0.6, 0.0),
                                                                KeypointOrder::mano21, 1.0)}}})}};
  path = write_keypoints("swapped.json", swapped);
  CHECK_THAT(handscs_test::error_of([&] { run_fit_command(options_for(path, "swapped")); }),
             Catch::Contains("the right hand's keypoints fit the other hand's rig far better"));
  // Missing points: a frame with only four is skipped with its reason, the others fitted.
  json sparse = doc_with("mano21", "m", 1.0);
  json few = sparse["frames"][0];
  few["name"] = "b";
  for (int j = 4; j < 21; ++j) few["right"][j] = nullptr;
  sparse["frames"].push_back(few);
  path = write_keypoints("sparse.json", sparse);
  FitCommandOptions o = options_for(path, "sparse");
  run_fit_command(o);
  std::ifstream in(o.out + "/report.json");
  const json report = json::parse(in);
  CHECK(report["hands"]["right"]["fitted"] == 1);
  CHECK(report["frames"][1]["status"] == "skipped: too few keypoints (4 of 21)");
}

TEST_CASE("handscs-fit: the report's bone-length error is the fitted joints' bones against the keypoints'") {
  // Keypoints with 4 mm of noise and a pinky stretched by 20%: bones the shape cannot all follow.
  auto joints = posed_joints(Handedness::right, 0.4, 0.0);
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 0.004);
  for (int j : {7, 8, 9, 20})  // pinky1-3 and its tip, stretched away from the wrist
    for (int i = 0; i < 3; ++i) joints[3 * j + i] = joints[i] + 1.2 * (joints[3 * j + i] - joints[i]);
  for (double& x : joints) x += noise(rng);
  const json doc = {{"format", "handscs-keypoints"}, {"order", "mano21"}, {"units", "m"},
                    {"frames", json::array({{{"name", "a"}, {"right", hand_entry(joints, KeypointOrder::mano21, 1.0)}}})}};
  FitCommandOptions o = options_for(write_keypoints("bones.json", doc), "bones");
  run_fit_command(o);
  std::ifstream poses_in(o.out + "/poses_right.json"), report_in(o.out + "/report.json");
  const json pose = json::parse(poses_in)["poses"][0];
  const json bones = json::parse(report_in)["hands"]["right"]["bone_length_error"];
  // The fitted joints again, from the POSES file through the rig, and every bone by its parent.
  auto tensor = [](const json& values) { return torch::tensor(values.get<std::vector<double>>(), torch::kFloat64); };
  const auto fitted = lbs_one_pose(make_procedural_hand(Handedness::right), tensor(pose["pose"]), tensor(pose["shape"]),
                                   tensor(pose["trans"]), LbsOptions{false})
                          .joints.reshape({21, 3});
  const int parent[21] = {-1, 0, 1, 2, 0, 4, 5, 0, 7, 8, 0, 10, 11, 0, 13, 14, 15, 3, 6, 12, 9};
  double sum = 0, sum_abs = 0, pinky = 0;
  for (int j = 1; j < 21; ++j) {
    const int p = parent[j];
    const double got = (fitted[j] - fitted[p]).norm().item<double>();
    const double want = std::hypot(joints[3 * j] - joints[3 * p], joints[3 * j + 1] - joints[3 * p + 1],
                                   joints[3 * j + 2] - joints[3 * p + 2]);
    sum += 1e3 * (got - want);
    sum_abs += 1e3 * std::fabs(got - want);
    if (j == 8 || j == 9 || j == 20) pinky += 1e3 * (got - want);
  }
  CHECK(bones["mean_mm"].get<double>() == Approx(sum / 20).margin(1e-3));
  CHECK(bones["mean_abs_mm"].get<double>() == Approx(sum_abs / 20).margin(1e-3));
  CHECK(bones["mean_abs_mm"].get<double>() > 0.5);  // the noise alone moves bones by millimetres
  // The pinky's bone from the knuckle (7 -> 8 etc.) and from the wrist (0 -> 7) are its four.
  const double pinky_from_wrist = (fitted[7] - fitted[0]).norm().item<double>() -
                                  std::hypot(joints[21] - joints[0], joints[22] - joints[1], joints[23] - joints[2]);
  CHECK(bones["per_finger_mean_mm"]["pinky"].get<double>() ==
        Approx((pinky + 1e3 * pinky_from_wrist) / 4).margin(1e-3));
}

TEST_CASE("handscs-fit: a rig file fits as the rig it holds (a converted MANO file is one)") {
  // The toy rig's pose blend shapes move the tips as MANO's do; the built-in hand has none.
  const std::string rig_path = handscs_test::scratch_path("fit_command", "toy_rig.json");
  Rig toy = make_procedural_hand(Handedness::right);
  torch::manual_seed(5);
  toy.posedirs = torch::randn(toy.posedirs.sizes(), torch::kFloat64) * 1e-3;
  toy.name = "toy";
  save_rig(toy, rig_path);
  const JointModel model = make_joint_model(toy);
  JointParams p;
  for (int k = 1; k < kRigJoints; ++k)
    for (int i = 0; i < 3; ++i) p.pose[3 * k + i] = 1.4 * model.hands_mean[3 * (k - 1) + i];
  p.trans = {0.0, 0.0, 1.0};
  std::array<double, 63> joints;
  joint_positions(model, p, joints.data());
  const json doc = {{"format", "handscs-keypoints"}, {"order", "interhand"}, {"units", "m"},
                    {"frames", json::array({{{"name", "a"}, {"right", hand_entry(joints, KeypointOrder::interhand, 1.0)}}})}};
  FitCommandOptions o = options_for(write_keypoints("toy.json", doc), "toy_rig");
  o.rig_right = rig_path;
  run_fit_command(o);
  std::ifstream in(o.out + "/report.json");
  CHECK(json::parse(in)["hands"]["right"]["mean_mm"].get<double>() < 0.5);
}

TEST_CASE("handscs-fit: real InterHand2.6M joints in a wrong order are refused as a poor fit") {
  // Capture 3's right hand from ../shared, written as it is (InterHand order) and mislabelled as
  // MediaPipe's order: the first fits to millimetres, the second fits nothing.
  std::ifstream in(std::string(HANDSCS_SHARED_DIR) + "/testdata/interhand2.6m/test_interhand2.6m_joint_3d.json");
  const json joints = json::parse(in)["3"]["69148"]["world_coord"];
  json right = json::array();
  for (int j = 0; j < 21; ++j) right.push_back(joints[j]);
  auto file = [&](const std::string& order) {
    return write_keypoints(order + "_order.json", {{"format", "handscs-keypoints"}, {"order", order}, {"units", "mm"},
                                                   {"frames", json::array({{{"name", "x"}, {"right", right}}})}});
  };
  FitCommandOptions good = options_for(file("interhand"), "good_order");
  run_fit_command(good);
  std::ifstream report(good.out + "/report.json");
  CHECK(json::parse(report)["hands"]["right"]["mean_mm"].get<double>() < 5.0);
  CHECK_THAT(handscs_test::error_of([&] { run_fit_command(options_for(file("mediapipe"), "wrong_order")); }),
             Catch::Contains("no hand could be fitted; right hand, frame x: poor fit (mean residual") &&
                 Catch::Contains("a wrong joint order, swapped hands or mislabelled joints"));
}
