// handscs-fit --keypoints with --capture-dir: a capture whose frames carry no hands gets the fitted
// ones, opens for training with the frames and images of the capture it came from, and every
// mismatch between the keypoint file and the capture is refused before anything is written.
#include <catch2/catch.hpp>

#include <algorithm>
#include <filesystem>
#include <fstream>

#include <nlohmann/json.hpp>

#include "core/config.h"
#include "data/capture.h"
#include "data/handscs_capture.h"
#include "data/synth_fixture.h"
#include "fit/fit_command.h"
#include "hand/lbs_one_pose.h"
#include "hand/procedural_hand.h"
#include "test_support.h"

using namespace handscs;
using nlohmann::json;
namespace fs = std::filesystem;

namespace {

struct BareCapture {
  std::string root;
  json truth;      // the source capture.json, hands included
  json keypoints;  // a keypoint file of its right hands' joints, every frame but the last
};

// The tiny capture in `layout` (handscs or easymocap) with its hands removed (images and
// calibration linked), and a keypoint file of its true joints named by frame number.
BareCapture bare_tiny_capture(const std::string& name, const std::string& layout = "handscs") {
  const std::string source = data_test::tiny_capture_in(layout);
  BareCapture bare;
  bare.root = data_test::fresh_dir(name);
  bare.truth = parse_json_file(source + "/capture.json");
  json doc = bare.truth;
  json frames = json::array();
  for (size_t k = 0; k < doc["frames"].size(); ++k) {
    json& f = doc["frames"][k];
    if (k + 1 < doc["frames"].size())
      frames.push_back({{"name", frame_file_stem(f["frame"].get<int64_t>())}, {"right", f["right"]["joints"]}});
    f["right"] = nullptr;
    f["left"] = nullptr;
    f.erase("hand_type");
  }
  std::ofstream(bare.root + "/capture.json") << doc.dump();
  for (const char* linked : {"images", "intri.yml", "extri.yml"})
    if (fs::exists(source + "/" + linked)) fs::create_symlink(source + "/" + linked, bare.root + "/" + linked);
  bare.keypoints = {{"format", "handscs-keypoints"}, {"order", "mano21"}, {"units", "m"}, {"frames", frames}};
  return bare;
}

FitCommandOptions options_for(const BareCapture& bare, const json& keypoints, const std::string& out_name) {
  FitCommandOptions o;
  o.keypoints = handscs_test::scratch_file("fitted_capture", out_name + ".json", keypoints.dump());
  o.capture_dir = bare.root;
  o.out = handscs_test::scratch_path("fitted_capture", out_name);
  fs::remove_all(o.out);
  return o;
}

torch::Tensor tensor_of(const json& values) {
  return torch::tensor(values.get<std::vector<double>>(), torch::kFloat64);
}

}  // namespace

TEST_CASE("handscs-fit --capture-dir: a capture without hands gets the fitted ones and opens as its source") {
  const BareCapture bare = bare_tiny_capture("fitted_capture_bare");
  const FitCommandOptions o = options_for(bare, bare.keypoints, "fitted");
  run_fit_command(o);

  const json written = parse_json_file(o.out + "/capture.json");
  CHECK(written["cameras"] == bare.truth["cameras"]);
  REQUIRE(written["frames"].size() == bare.truth["frames"].size());
  const Rig rig = make_procedural_hand(Handedness::right);
  const size_t last = written["frames"].size() - 1;
  for (size_t k = 0; k < written["frames"].size(); ++k) {
    const json& f = written["frames"][k];
    INFO("frame " << f["frame"]);
    CHECK(f["frame"] == bare.truth["frames"][k]["frame"]);
    CHECK(f["left"].is_null());
    if (k == last) {  // no keypoints: written without hands
      CHECK(f["right"].is_null());
      CHECK_FALSE(f.contains("hand_type"));
      continue;
    }
    CHECK(f["hand_type"] == "right");
    // The written parameters pose the rig onto the true joints (the keypoints).
    const LbsOutput posed = lbs_one_pose(rig, tensor_of(f["right"]["pose"]), tensor_of(f["right"]["shape"]),
                                         tensor_of(f["right"]["trans"]), LbsOptions{false});
    const auto got = posed.joints.reshape({21, 3});
    std::vector<double> true_joints;
    for (const json& row : bare.truth["frames"][k]["right"]["joints"])
      for (const json& x : row) true_joints.push_back(x.get<double>());
    const auto truth = torch::tensor(true_joints, torch::kFloat64).reshape({21, 3});
    const double mean_mm = 1e3 * (got - truth).norm(2, {1}).mean().item<double>();
    CHECK(mean_mm < 0.5);
  }

  // It opens for training: the source's frames and images, less the frame without a hand.
  const Capture source = Capture::open(data_test::tiny_config(data_test::tiny_capture_in("handscs")));
  const Capture fitted = Capture::open(data_test::tiny_config(o.out));
  const int64_t cameras = static_cast<int64_t>(bare.truth["cameras"].size());
  CHECK(static_cast<int64_t>(fitted.frames().size()) == static_cast<int64_t>(source.frames().size()) - cameras);
  const FrameInfo& first = fitted.frames().front();
  const auto same = std::find_if(source.frames().begin(), source.frames().end(), [&](const FrameInfo& f) {
    return f.frame_idx == first.frame_idx && f.camera_id == first.camera_id;
  });
  REQUIRE(same != source.frames().end());
  CHECK(fs::equivalent(first.image_path, same->image_path));
}

TEST_CASE("handscs-fit --capture-dir: an EasyMocap capture stays one, its calibration linked") {
  const BareCapture bare = bare_tiny_capture("fitted_capture_easymocap", "easymocap");
  const FitCommandOptions o = options_for(bare, bare.keypoints, "fitted_easymocap");
  run_fit_command(o);
  CHECK_FALSE(parse_json_file(o.out + "/capture.json").contains("cameras"));
  for (const char* linked : {"intri.yml", "extri.yml", "images"}) CHECK(fs::is_symlink(o.out + "/" + linked));
  const Capture source = Capture::open(data_test::tiny_config(data_test::tiny_capture_in("easymocap")));
  const Capture fitted = Capture::open(data_test::tiny_config(o.out));
  const int64_t cameras = static_cast<int64_t>(source.frames().size() / bare.truth["frames"].size());
  CHECK(static_cast<int64_t>(fitted.frames().size()) == static_cast<int64_t>(source.frames().size()) - cameras);
}

TEST_CASE("handscs-fit --capture-dir: frames the capture does not have are refused before anything is written") {
  const BareCapture bare = bare_tiny_capture("fitted_capture_refusals");
  auto with_names = [&](const std::vector<std::string>& names) {
    json k = bare.keypoints;
    k["frames"] = json::array();
    for (size_t i = 0; i < names.size(); ++i)
      k["frames"].push_back({{"name", names[i]}, {"right", bare.keypoints["frames"][i]["right"]}});
    return k;
  };
  const std::string kp_file = fs::path(handscs_test::scratch_path("fitted_capture", "names.json")).string();
  const std::string capture_json = bare.root + "/capture.json";
  struct Case {
    std::vector<std::string> names;
    std::string error;
  };
  const json& frames = bare.truth["frames"];
  const std::string range = std::to_string(frames.size()) + " frames, numbered " + frames.front()["frame"].dump() +
                            "-" + frames.back()["frame"].dump();
  const std::string second = frames[1]["frame"].dump();  // named twice below, once padded
  const std::string padded = frame_file_stem(frames[1]["frame"].get<int64_t>());
  for (const Case& c : std::vector<Case>{
           {{"000000", "f1"},
            kp_file + ": frame \"f1\": with --capture-dir, a frame's name is its frame number in " + bare.root +
                " (\"000042\" or \"42\")"},
           {{"000999"}, kp_file + ": frame \"000999\" is not a frame of " + capture_json + " (" + range + ")"},
           {{second, padded},
            kp_file + ": frames \"" + second + "\" and \"" + padded + "\" both name frame " + second + " of " + bare.root},
       }) {
    FitCommandOptions o = options_for(bare, with_names(c.names), "names");
    CHECK(handscs_test::error_of([&] { run_fit_command(o); }) == c.error);
    CHECK_FALSE(fs::exists(o.out));
  }
  // Leading zeros beyond 18 digits still name a frame; 19 significant digits name none.
  {
    json k = bare.keypoints;
    k["frames"] = json::array({{{"name", std::string(20, '0') + second}, {"right", bare.keypoints["frames"][1]["right"]}}});
    FitCommandOptions o = options_for(bare, k, "zeros");
    run_fit_command(o);
    CHECK(parse_json_file(o.out + "/capture.json")["frames"][1]["hand_type"] == "right");
    k["frames"][0]["name"] = "1234567890123456789";
    o = options_for(bare, k, "too_long");
    CHECK_THAT(handscs_test::error_of([&] { run_fit_command(o); }),
               Catch::Contains(": frame \"1234567890123456789\": with --capture-dir, a frame's name is its frame number"));
  }
  // The capture inside the folder the fit replaces; a link in it that leads nowhere: refused before
  // fitting, and the earlier fit in --out is kept.
  {
    FitCommandOptions o = options_for(bare, bare.keypoints, "holder");
    run_fit_command(o);
    const std::string inner = o.out + "/recording";
    fs::create_directories(inner);
    fs::copy(bare.root + "/capture.json", inner + "/capture.json");
    fs::create_symlink(fs::read_symlink(bare.root + "/images"), inner + "/images");
    const auto before = handscs_test::snapshot(o.out);
    FitCommandOptions again = o;
    again.capture_dir = inner;
    again.overwrite = true;
    CHECK(handscs_test::error_of([&] { run_fit_command(again); }) ==
          "--capture-dir " + inner + " lies inside --out " + o.out +
              ", which the fit replaces: the written capture would link into what it removes");
    CHECK(handscs_test::snapshot(o.out) == before);
    const std::string broken = data_test::fresh_dir("fitted_capture_broken_link");
    fs::copy(bare.root + "/capture.json", broken + "/capture.json");
    fs::create_symlink(fs::read_symlink(bare.root + "/images"), broken + "/images");
    fs::create_symlink("/nonexistent/regions", broken + "/regions");
    FitCommandOptions dangling = options_for(bare, bare.keypoints, "dangling");
    dangling.capture_dir = broken;
    CHECK_THAT(handscs_test::error_of([&] { run_fit_command(dangling); }),
               Catch::StartsWith(broken + "/regions: cannot be resolved (") &&
                   Catch::EndsWith("); the written capture links to it"));
    CHECK_FALSE(fs::exists(dangling.out));
  }
  // Not a capture in the project's layout; not with a multi-view capture.
  FitCommandOptions o = options_for(bare, bare.keypoints, "not_a_capture");
  o.capture_dir = data_test::fresh_dir("fitted_capture_empty");
  CHECK(handscs_test::error_of([&] { run_fit_command(o); }) ==
        o.capture_dir + ": holds no capture.json (--capture-dir takes a capture in the project's or EasyMocap's "
                        "layout, docs/CAPTURE_FORMAT.md; its frames may carry no hands)");
  o.capture_dir = bare.root;
  o.multiview = "/some/views";
  o.keypoints.clear();
  CHECK(handscs_test::error_of([&] { run_fit_command(o); }) ==
        "--capture-dir goes with --keypoints (a multi-view capture writes its own capture.json; an InterHand2.6M "
        "capture trains from its joints with data.pose_source=joints)");
  CHECK_FALSE(fs::exists(o.out));
}
