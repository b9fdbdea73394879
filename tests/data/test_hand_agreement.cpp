// A capture whose MANO parameters and joints disagree about which hand is which: both hands'
// entries swapped, one hand's parameters copied to the other, a one-hand capture holding the
// other hand. The generator's joints are the reference: its own (reflected) hands, posed by an
// independent path, against the reader's joint model.
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "data_test_helpers.h"
#include "synth_fixture.h"
#include "core/error.h"
#include "data/capture.h"
#include "data/hand_agreement.h"
#include "data/handscs_capture.h"

// Catch last: LibTorch pulls in glog, whose CHECK macro would otherwise replace Catch's.
#include <catch2/catch.hpp>

using namespace handscs;
namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

// both_tiny in the handscs layout, written once per process.
const std::string& two_hand_root() {
  static const std::string root = [] {
    const std::string dir = data_test::fresh_dir("agreement_source");
    SynthConfig config = synth_preset("both_tiny");
    config.layout = CaptureConfig::Layout::handscs;
    write_synth_capture(make_synth_scene(config), dir);
    return dir;
  }();
  return root;
}

// A copy of the two-hand capture whose capture.json `edit` changes frame by frame.
template <typename Edit>
std::string edited_copy(const std::string& name, Edit edit) {
  const std::string dir = data_test::fresh_dir(name);
  fs::copy(two_hand_root(), dir, fs::copy_options::recursive | fs::copy_options::overwrite_existing);
  const std::string file = dir + "/capture.json";
  json capture = json::parse(std::ifstream(file));
  for (json& frame : capture["frames"]) edit(frame);
  std::ofstream(file) << capture.dump();
  return dir;
}

CaptureConfig config_of(const std::string& root, CaptureConfig::Hands hands) {
  CaptureConfig config = data_test::tiny_config(root);
  config.hand = hands;
  config.layout = CaptureConfig::Layout::handscs;
  config.include_interacting = true;  // both_tiny marks its frames interacting
  return config;
}

std::string open_error(const CaptureConfig& config) {
  try {
    Capture::open(config);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

CaptureRecords records_of(const CaptureConfig& config) {
  return read_handscs_capture(config.root, config.layout, config.flat_hand_mean, "data.flat_hand_mean");
}

}  // namespace

TEST_CASE("hand agreement: a capture's own hands agree with their joints, the other hand does not") {
  const CaptureConfig config = config_of(two_hand_root(), CaptureConfig::Hands::both);
  const CaptureRecords records = records_of(config);
  for (const Handedness side : {Handedness::right, Handedness::left}) {
    INFO(hand_name(side));
    const HandAgreement a = measure_hand_agreement(records, side, capture_rig(config, side), config.flat_hand_mean);
    CHECK(a.frames == static_cast<int>(records.frames.size()));
    // The generator wrote the joints of the hands it drew: the joint model reproduces them to
    // float rounding of the written file.
    CHECK(a.own_mm < 0.01);
    // Mirrored fingers and a hand ~10 cm away are both centimetres off.
    CHECK(a.other_rig_mm > 5.0);
    CHECK(a.other_joints_mm > 50.0);
  }
  CHECK(open_error(config).empty());
}

TEST_CASE("hand agreement: swapped hands are refused by name") {
  const std::string root = edited_copy("agreement_swapped", [](json& frame) { std::swap(frame["right"], frame["left"]); });
  const std::string error = open_error(config_of(root, CaptureConfig::Hands::both));
  INFO(error);
  CHECK(error.find(root + "/capture.json") != std::string::npos);
  CHECK(error.find("the right hand's MANO parameters fit the left hand's rig far better") != std::string::npos);
  CHECK(error.find("swapped") != std::string::npos);
  // One hand selected: its entry holds the other hand.
  CHECK(open_error(config_of(root, CaptureConfig::Hands::right)).find("swapped") != std::string::npos);
  CHECK(open_error(config_of(root, CaptureConfig::Hands::left)).find("the left hand's") != std::string::npos);
}

TEST_CASE("hand agreement: one hand's parameters copied to the other are refused") {
  const std::string root = edited_copy("agreement_copied", [](json& frame) {
    for (const char* key : {"pose", "shape", "trans"}) frame["left"][key] = frame["right"][key];
  });
  const std::string error = open_error(config_of(root, CaptureConfig::Hands::both));
  INFO(error);
  CHECK(error.find("the left hand's MANO parameters") != std::string::npos);
  CHECK(error.find("copied in") != std::string::npos);
  // The right hand alone is as it was.
  CHECK(open_error(config_of(root, CaptureConfig::Hands::right)).empty());
}

TEST_CASE("hand agreement: parameters swapped but joints kept are refused") {
  const std::string root = edited_copy("agreement_params_swapped", [](json& frame) {
    for (const char* key : {"pose", "shape", "trans"}) std::swap(frame["right"][key], frame["left"][key]);
  });
  const std::string error = open_error(config_of(root, CaptureConfig::Hands::both));
  INFO(error);
  CHECK(error.find("the right hand's MANO parameters") != std::string::npos);
  CHECK(error.find("swapped") != std::string::npos);
}

TEST_CASE("hand agreement: hands without joints are not measured") {
  const std::string root = edited_copy("agreement_no_joints", [](json& frame) {
    frame["right"].erase("joints");
    frame["left"].erase("joints");
    std::swap(frame["right"], frame["left"]);
  });
  const CaptureConfig config = config_of(root, CaptureConfig::Hands::both);
  const HandAgreement a =
      measure_hand_agreement(records_of(config), Handedness::right, capture_rig(config, Handedness::right), false);
  CHECK(a.frames == 0);
  CHECK(std::isnan(a.own_mm));
  CHECK(open_error(config).empty());  // nothing to tell them apart by: not refused
}

TEST_CASE("hand agreement: only the frames the run uses are measured") {
  // Frames of sequence "b" have their hands swapped; a run on sequence "a" never sees them.
  int k = 0;
  const std::string root = edited_copy("agreement_sequences", [&](json& frame) {
    const bool second_half = k++ >= 6;  // both_tiny has 12 poses
    frame["sequence"] = second_half ? "b" : "a";
    if (second_half) std::swap(frame["right"], frame["left"]);
  });
  CaptureConfig config = config_of(root, CaptureConfig::Hands::both);
  config.sequences = {"a"};
  CHECK(open_error(config).empty());
  config.sequences = {"b"};
  CHECK(open_error(config).find("swapped") != std::string::npos);
}
