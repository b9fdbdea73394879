// The tiny synthetic capture shared by the round-trip tests: generated once per test process into a
// process-private temporary folder (ctest may run test cases in parallel), removed at exit.
#pragma once

#include <unistd.h>

#include <filesystem>
#include <map>
#include <memory>
#include <string>

#include "data/capture.h"
#include "synth/capture.h"
#include "data_test_helpers.h"

namespace data_test {

struct TinyCapture {
  handscs::SynthScene scene;
  std::string root;
  ~TinyCapture() {
    std::error_code ec;
    std::filesystem::remove_all(root, ec);
  }
};

inline const TinyCapture& tiny_capture() {
  static std::unique_ptr<TinyCapture> tiny = [] {
    auto t = std::make_unique<TinyCapture>();
    t->root = (std::filesystem::temp_directory_path() /
               ("handscs_test_data_tiny_" + std::to_string(::getpid())))
                  .string();
    std::filesystem::remove_all(t->root);
    t->scene = handscs::make_synth_scene(handscs::synth_preset("tiny"));
    handscs::write_synth_capture(t->scene, t->root);
    return t;
  }();
  return *tiny;
}

// Copies the tiny capture into a fresh folder `name` (for tests that damage it).
inline std::string copy_of_tiny(const std::string& name) {
  const std::string dir = fresh_dir(name);
  std::filesystem::copy(tiny_capture().root, dir, std::filesystem::copy_options::recursive);
  return dir;
}

// The tiny capture written in `layout` ("interhand", "handscs", "easymocap"), once per process.
inline const std::string& tiny_capture_in(const std::string& layout) {
  static std::map<std::string, std::unique_ptr<TinyCapture>> captures;
  auto& capture = captures[layout];
  if (!capture) {
    capture = std::make_unique<TinyCapture>();
    capture->root = (std::filesystem::temp_directory_path() /
                     ("handscs_test_data_tiny_" + layout + "_" + std::to_string(::getpid())))
                        .string();
    std::filesystem::remove_all(capture->root);
    handscs::SynthConfig config = handscs::synth_preset("tiny");
    config.layout = handscs::choice_value(layout, handscs::SynthConfig::layout_names());
    capture->scene = handscs::make_synth_scene(config);
    handscs::write_synth_capture(capture->scene, capture->root);
  }
  return capture->root;
}

// Copies the tiny capture in `layout` into a fresh folder `name`.
inline std::string copy_of_tiny_in(const std::string& layout, const std::string& name) {
  const std::string dir = fresh_dir(name);
  std::filesystem::copy(tiny_capture_in(layout), dir, std::filesystem::copy_options::recursive);
  return dir;
}

// Capture config for the tiny capture (12 poses: hold out 3).
inline handscs::CaptureConfig tiny_config(const std::string& root) {
  handscs::CaptureConfig config;
  config.root = root;
  config.held_out_poses = 3;
  config.cache.prefetch_threads = 0;
  return config;
}

}  // namespace data_test
