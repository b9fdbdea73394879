// Small helpers shared by test files that need no torch: the text of an expected error, and a
// scratch file under the system temp folder.
#pragma once

#include <exception>
#include <filesystem>
#include <fstream>
#include <functional>
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

}  // namespace handscs_test
