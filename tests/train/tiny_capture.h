// Test fixture: the `tiny` synthetic capture, written once per test process into a temp folder, and
// a run config pointing at it (3 held-out poses, so both splits are non-empty).
#pragma once

#include <filesystem>
#include <string>

#include "run/run_config.h"
#include "synth/capture.h"
#include "synth/config.h"

namespace handscs_test {

inline const std::string& tiny_capture_dir() {
  static const std::string dir = [] {
    const auto path = std::filesystem::temp_directory_path() /
                      ("handscs_tiny_capture_" + std::to_string(::getpid()));
    std::filesystem::remove_all(path);
    handscs::generate_synth_capture(handscs::synth_preset("tiny"), path.string());
    return path.string();
  }();
  return dir;
}

inline handscs::RunConfig tiny_run_config() {
  handscs::RunConfig config;
  config.data.root = tiny_capture_dir();
  config.data.held_out_poses = 3;
  config.train.iterations = 100;
  config.train.checkpoint_every = 50;
  config.train.validate_every = 0;
  config.train.log_every = 10;
  return config;
}

inline std::string fresh_dir(const std::string& name) {
  const auto path = std::filesystem::temp_directory_path() /
                    ("handscs_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(path);
  return path.string();
}

}  // namespace handscs_test
