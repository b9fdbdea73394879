// Small helpers shared by test files that need no torch: the text of an expected error, a scratch
// file under the system temp folder, a folder's files and bytes, the repository and program paths.
#pragma once

#include <exception>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <map>
#include <string>

namespace handscs_test {

// Text of the exception f throws, "(no error)" when it throws none: tests assert exact messages.
inline std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "(no error)";
}

// Path of `name` in <temp>/<folder>/ (the folder is created).
inline std::string scratch_path(const std::string& folder, const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() / folder;
  std::filesystem::create_directories(dir);
  return (dir / name).string();
}

// Writes `text` to scratch_path(folder, name) and returns the path.
inline std::string scratch_file(const std::string& folder, const std::string& name,
                                const std::string& text) {
  const std::string path = scratch_path(folder, name);
  std::ofstream(path) << text;
  return path;
}

// Every file under `dir` with its bytes (to prove a command changed nothing).
inline std::map<std::string, std::string> snapshot(const std::string& dir) {
  std::map<std::string, std::string> files;
  for (const auto& entry : std::filesystem::recursive_directory_iterator(dir)) {
    if (!entry.is_regular_file()) continue;
    std::ifstream in(entry.path(), std::ios::binary);
    files[entry.path().string()] = std::string(std::istreambuf_iterator<char>(in), {});
  }
  return files;
}

#ifdef HANDSCS_SOURCE_DIR
inline const std::string kSource = HANDSCS_SOURCE_DIR;  // the repository (configs/, docs/, scripts/)
inline const std::string kBin = HANDSCS_BIN_DIR;        // the built programs
// The LPIPS AlexNet weights in ../shared (read in place, never copied).
inline const std::string kLpipsAlexWeights = std::string(HANDSCS_SHARED_DIR) + "/assets/lpips/lpips_alex_v0.1.pt";
#endif

}  // namespace handscs_test
