#include "sweep/run_resume.h"

#include <sys/stat.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <regex>

#include "core/atomic_file.h"

namespace handscs {

namespace fs = std::filesystem;

namespace {

const char kIdentityFile[] = "/sweep_run.json";

}  // namespace

std::string sweep_run_identity(const std::vector<std::string>& train_argv, const std::string& run_dir) {
  nlohmann::json command = nlohmann::json::array();
  for (const auto& arg : train_argv) command.push_back(arg == run_dir ? std::string("RUN") : arg);
  nlohmann::json binary = nullptr;
  struct stat info {};
  if (!train_argv.empty() && ::stat(train_argv.front().c_str(), &info) == 0)
    binary = {{"bytes", static_cast<long long>(info.st_size)},
              {"modified_ns", static_cast<long long>(info.st_mtim.tv_sec) * 1000000000LL +
                                  info.st_mtim.tv_nsec}};
  return nlohmann::json{{"train_command", command}, {"train_binary", binary}}.dump(1) + "\n";
}

bool sweep_run_resumable(const std::string& run_dir, const std::string& identity) {
  std::error_code ec;
  if (!fs::is_regular_file(run_dir + kIdentityFile, ec)) return false;
  try {
    if (read_file(run_dir + kIdentityFile) != identity) return false;
  } catch (const std::exception&) {
    return false;  // unreadable: the run is started afresh, as one without the file
  }
  const fs::path checkpoints = fs::path(run_dir) / "checkpoints";
  if (!fs::is_directory(checkpoints, ec)) return false;
  for (const auto& entry : fs::directory_iterator(checkpoints, ec)) {
    const std::string name = entry.path().filename().string();
    if (name.rfind("step_", 0) == 0 && entry.path().extension() == ".ckpt") return true;
  }
  return false;
}

void record_sweep_run(const std::string& run_dir, const std::string& identity) {
  write_file_atomic(run_dir + kIdentityFile, identity);
}

long long resumed_step_in_log(const std::string& train_log) {
  std::ifstream in(train_log);
  const std::regex resumed("resumed from .* at step ([0-9]+)");
  std::string line;
  std::smatch match;
  while (std::getline(in, line))
    if (std::regex_search(line, match, resumed)) return std::stoll(match[1].str());
  return -1;
}

}  // namespace handscs
