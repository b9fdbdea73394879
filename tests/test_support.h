// Small helpers shared by test files that need no torch: the text of an expected error, a scratch
// file under the system temp folder, a folder's files and bytes, the repository and program paths,
// and a program started in the background to be signalled.
#pragma once

#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <map>
#include <string>
#include <thread>

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

// Sets an environment variable for one scope, then restores what it was (or unsets it).
struct ScopedEnv {
  ScopedEnv(std::string name, const std::string& value) : name_(std::move(name)) {
    const char* previous = std::getenv(name_.c_str());
    had_ = previous != nullptr;
    if (had_) old_ = previous;
    ::setenv(name_.c_str(), value.c_str(), 1);
  }
  ~ScopedEnv() {
    if (had_)
      ::setenv(name_.c_str(), old_.c_str(), 1);
    else
      ::unsetenv(name_.c_str());
  }
  ScopedEnv(const ScopedEnv&) = delete;
  ScopedEnv& operator=(const ScopedEnv&) = delete;

 private:
  std::string name_, old_;
  bool had_ = false;
};

// Starts `command` through /bin/sh in the background (exec'd: the pid is the program's own, so a
// signal sent to it reaches the program). Returns the pid.
inline pid_t spawn(const std::string& command) {
  const pid_t pid = fork();
  if (pid == 0) {
    execl("/bin/sh", "sh", "-c", ("exec " + command).c_str(), nullptr);
    _exit(127);
  }
  return pid;
}

// Polls `ready` every 20 ms for up to `seconds`; whether it came true.
inline bool wait_until(const std::function<bool()>& ready, double seconds = 60) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (!ready()) {
    if (std::chrono::steady_clock::now() > end) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return true;
}

// Waits for `pid` to end: its exit code, or -1 when a signal ended it.
inline int exit_code_of(pid_t pid) {
  int status = 0;
  waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
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
