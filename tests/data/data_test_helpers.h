// Shared helpers of the data tests: temporary folders, error capture, the real InterHand samples.
#pragma once

#include <filesystem>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

#include <unistd.h>

#include "test_support.h"

namespace data_test {

inline std::string samples_dir() {
  return std::string(HANDSCS_SHARED_DIR) + "/testdata/interhand2.6m";
}

// Folders made by fresh_dir, removed when the test process exits.
struct TempDirs {
  std::vector<std::string> paths;
  ~TempDirs() {
    for (const auto& path : paths) {
      std::error_code ec;
      std::filesystem::remove_all(path, ec);
    }
  }
};
inline TempDirs& temp_dirs() {
  static TempDirs dirs;
  return dirs;
}

// A fresh, empty folder under the system temp folder, private to this process (ctest may run
// test processes in parallel) and removed at exit.
inline std::string fresh_dir(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() /
                   ("handscs_test_data_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  temp_dirs().paths.push_back(dir.string());
  return dir.string();
}

inline std::string write_text(const std::string& path, const std::string& text) {
  std::filesystem::create_directories(std::filesystem::path(path).parent_path());
  std::ofstream(path, std::ios::binary) << text;
  return path;
}

using handscs_test::error_of;

}  // namespace data_test
