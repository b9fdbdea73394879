// Test fixture: a two-hand capture in the project's layout, made from the `tiny` synthetic capture
// (written in that layout): every frame keeps its right hand and gains a left hand, the right
// hand's mirror image through x = 0 (synth/mirror.h) moved `left_offset_x` along x. The images still show the right hand alone: the fixture tests the
// mechanics of two hands (masks, training, checkpoints), not what a left hand looks like.
#pragma once

#include <filesystem>
#include <fstream>
#include <set>
#include <string>

#include <nlohmann/json.hpp>

#include "core/atomic_file.h"
#include "synth/capture.h"
#include "synth/config.h"
#include "synth/mirror.h"

namespace handscs_test {

struct TwoHandCaptureSpec {
  double left_offset_x = 0.06;  // m: beside the right hand, partly overlapping it in most views
  std::set<int64_t> without_left;  // frame numbers whose left hand is null
  bool no_left = false;            // every frame's left hand null
};

// Gives every frame of the capture.json in `dir` (the project's layout) a left hand as the spec says.
inline void add_left_hands(const std::string& dir, const TwoHandCaptureSpec& spec = {}) {
  const std::string path = dir + "/capture.json";
  nlohmann::json capture = nlohmann::json::parse(std::ifstream(path));
  for (auto& frame : capture["frames"]) {
    const int64_t number = frame["frame"].get<int64_t>();
    frame["hand_type"] = "interacting";
    if (spec.no_left || spec.without_left.count(number)) {
      frame["left"] = nullptr;
      continue;
    }
    nlohmann::json left = frame["right"];
    left.erase("joints");
    left.erase("joint_valid");
    left["pose"] = handscs::mirror_mano_pose(left["pose"].get<std::array<double, 48>>());
    auto trans = handscs::mirror_point(left["trans"].get<std::array<double, 3>>());
    trans[0] += spec.left_offset_x;
    left["trans"] = trans;
    frame["left"] = left;
  }
  handscs::write_file_atomic(path, capture.dump(1));
}

// Writes the tiny capture with left hands into `dir` (replaced) and returns it.
inline std::string make_two_hand_capture(const std::string& dir, const TwoHandCaptureSpec& spec = {}) {
  std::filesystem::remove_all(dir);
  handscs::SynthConfig synth = handscs::synth_preset("tiny");
  synth.layout = handscs::CaptureConfig::Layout::handscs;
  handscs::generate_synth_capture(synth, dir);
  add_left_hands(dir, spec);
  return dir;
}

}  // namespace handscs_test
