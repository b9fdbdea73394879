#include "sweep/run_resume.h"

#include <sys/stat.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <optional>
#include <regex>

#include "core/atomic_file.h"
#include "core/config.h"

namespace handscs {

namespace fs = std::filesystem;

namespace {

std::string identity_path(const std::string& run_dir) {
  return (fs::path(run_dir) / "sweep_run.json").string();
}

// Of the first line of the log that matches `pattern`: its first group (the whole match when the
// pattern has none); nothing when no line matches.
std::optional<std::string> first_match(const std::string& train_log, const std::regex& pattern) {
  std::ifstream in(train_log);
  std::smatch match;
  for (std::string line; std::getline(in, line);)
    if (std::regex_search(line, match, pattern)) return match[match.size() > 1 ? 1 : 0].str();
  return std::nullopt;
}

}  // namespace

std::string sweep_run_identity(const std::vector<std::string>& train_argv, const std::string& run_dir,
                               const std::string& run_config) {
  nlohmann::json command = nlohmann::json::array();
  for (const auto& arg : train_argv) command.push_back(arg == run_dir ? std::string("RUN") : arg);
  nlohmann::json config;
  try {
    config = load_json_file(run_config);
  } catch (const std::exception& e) {
    config = std::string("unreadable: ") + e.what();  // the training attempt reports it
  }
  nlohmann::json binary = nullptr;
  struct stat info {};
  if (!train_argv.empty() && ::stat(train_argv.front().c_str(), &info) == 0)
    binary = {{"bytes", static_cast<long long>(info.st_size)},
              {"modified_ns", static_cast<long long>(info.st_mtim.tv_sec) * 1000000000LL +
                                  info.st_mtim.tv_nsec}};
  return nlohmann::json{{"train_command", command}, {"run_config", config}, {"train_binary", binary}}
             .dump(1) +
         "\n";
}

bool sweep_run_resumable(const std::string& run_dir, const std::string& identity) {
  try {
    // A larger file cannot be this identity: refused unread, however large.
    if (read_file(identity_path(run_dir), identity.size()) != identity) return false;
  } catch (const std::exception&) {
    return false;  // missing or unreadable: the run is started afresh
  }
  std::error_code ec;
  const fs::path checkpoints = fs::path(run_dir) / "checkpoints";
  if (!fs::is_directory(checkpoints, ec)) return false;
  for (const auto& entry : fs::directory_iterator(checkpoints, ec)) {
    const std::string name = entry.path().filename().string();
    if (name.rfind("step_", 0) == 0 && entry.path().extension() == ".ckpt") return true;
  }
  return false;
}

void record_sweep_run(const std::string& run_dir, const std::string& identity) {
  write_file_atomic(identity_path(run_dir), identity);
}

void keep_interrupted_log(const std::string& run_dir) {
  const fs::path log = fs::path(run_dir) / "train.log";
  std::error_code ec;
  if (!fs::exists(log, ec)) return;
  for (int n = 1;; ++n) {
    const fs::path kept = fs::path(run_dir) / ("train.interrupted." + std::to_string(n) + ".log");
    if (fs::exists(kept, ec)) continue;
    fs::rename(log, kept, ec);
    return;
  }
}

long long resumed_step_in_log(const std::string& train_log) {
  const auto step = first_match(train_log, std::regex("resumed from .* at step ([0-9]+)"));
  return step ? std::stoll(*step) : -1;
}

bool checkpoints_refused_in_log(const std::string& train_log) {
  return first_match(train_log, std::regex("be resumed; nothing was changed")).has_value();
}

}  // namespace handscs
