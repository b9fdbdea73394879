#include "train/set_aside_run.h"

#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <filesystem>
#include <vector>

#include <spdlog/spdlog.h>

#include "core/error.h"
#include "core/text.h"
#include "run/checkpoint.h"
#include "train/run_folder.h"

namespace handscs {

namespace fs = std::filesystem;

namespace {

// The files one run writes into its folder (the mask cache, cache/, is shared and stays).
const std::vector<std::string> kRunEntries = {"checkpoints", "config.json", "metrics.csv",      "pose_refine.csv",
                                              "validation",  "eval",        "camera_color.csv", "left"};
const std::string kAsidePrefix = ".overwritten.";

bool entry_exists(const fs::path& path) {
  std::error_code ec;
  return fs::symlink_status(path, ec).type() != fs::file_type::not_found && !ec;
}

void move(const fs::path& from, const fs::path& to) {
  std::error_code ec;
  fs::rename(from, to, ec);
  if (ec) throw Error(from.string() + ": cannot move it to " + to.string() + " (" + ec.message() + ")");
}

// Moves every run entry of `from` into `to` (created); on a failure the entries already moved go
// back before the error is thrown.
void move_entries(const fs::path& from, const fs::path& to) {
  std::vector<std::string> moved;
  try {
    fs::create_directories(to);
    for (const auto& name : kRunEntries) {
      if (!entry_exists(from / name)) continue;
      move(from / name, to / name);
      moved.push_back(name);
    }
  } catch (...) {
    for (const auto& name : moved) {
      std::error_code ec;
      fs::rename(to / name, from / name, ec);
    }
    throw;
  }
}

// The run entries of `dir` that exist.
std::vector<std::string> present_entries(const fs::path& dir) {
  std::vector<std::string> present;
  for (const auto& name : kRunEntries)
    if (entry_exists(dir / name)) present.push_back(name);
  return present;
}

// Removes the run entries of `dir` other than `kept`; returns the names removed.
std::vector<std::string> remove_entries(const fs::path& dir, const std::vector<std::string>& kept = {}) {
  std::vector<std::string> removed;
  for (const auto& name : present_entries(dir)) {
    if (std::find(kept.begin(), kept.end(), name) != kept.end()) continue;
    std::error_code ec;
    fs::remove_all(dir / name, ec);
    if (ec) throw Error((dir / name).string() + ": cannot remove it (" + ec.message() + ")");
    removed.push_back(name);
  }
  return removed;
}

void put_back(const fs::path& dir, const fs::path& aside) {
  remove_entries(dir);
  move_entries(aside, dir);
  fs::remove(aside);
}

}  // namespace

SetAsideRun::SetAsideRun(const std::string& dir) : dir_(dir) {
  const auto contents = inspect_run_folder(dir);
  if (!contents.holds_run()) {
    kept_ = present_entries(dir);
    return;
  }
  described_ = contents.describe();
  const fs::path aside = fs::path(dir) / (kAsidePrefix + std::to_string(::getpid()));
  move_entries(dir, aside);
  aside_ = aside.string();
  spdlog::warn("--overwrite: the run in {} ({}) is set aside in {} and deleted when the new run "
               "writes its first checkpoint", dir, described_, aside_);
}

SetAsideRun::~SetAsideRun() {
  if (settled_) return;
  try {
    restore();
  } catch (const std::exception& e) {
    if (aside_.empty()) spdlog::error("{}", e.what());
    else spdlog::error("{}; the earlier run's files are in {}", e.what(), aside_);
  }
}

void SetAsideRun::discard() {
  settled_ = true;
  if (aside_.empty()) return;
  std::error_code ec;
  fs::remove_all(aside_, ec);
  if (ec) spdlog::warn("{}: cannot delete the replaced run ({})", aside_, ec.message());
  else spdlog::info("--overwrite: deleted the replaced run ({})", described_);
  aside_.clear();
}

void SetAsideRun::restore() {
  if (settled_) return;
  settled_ = true;
  if (aside_.empty()) {
    const std::vector<std::string> removed = remove_entries(dir_, kept_);
    if (!removed.empty())
      spdlog::warn("the run ended before its first checkpoint: removed what it wrote in {} ({}); a "
                   "rerun needs no --overwrite", dir_, join(removed, ", "));
    return;
  }
  put_back(dir_, aside_);
  spdlog::warn("the new run ended before its first checkpoint: the earlier run in {} ({}) is back "
               "as it was", dir_, described_);
  aside_.clear();
}

void recover_set_aside_runs(const std::string& dir) {
  std::error_code ec;
  std::vector<fs::path> found;
  for (const auto& entry : fs::directory_iterator(dir, ec)) {
    const auto name = entry.path().filename().string();
    if (name.rfind(kAsidePrefix, 0) == 0) found.push_back(entry.path());
  }
  for (const auto& aside : found) {
    const std::string pid_text = aside.filename().string().substr(kAsidePrefix.size());
    long pid = 0;
    try {
      pid = std::stol(pid_text);
    } catch (const std::exception&) {
      continue;  // not ours
    }
    // kill(pid, 0) succeeds (or fails with EPERM) while that process lives.
    if (pid > 0 && pid != ::getpid() && (kill(static_cast<pid_t>(pid), 0) == 0 || errno == EPERM))
      throw Error(dir + ": another handscs-train (process " + pid_text +
                  ") is replacing the run in this folder; wait for it or choose another --out");
    if (!list_checkpoints(dir).empty()) {
      fs::remove_all(aside, ec);
      spdlog::warn("{}: deleted the run an interrupted --overwrite had set aside (the new run had "
                   "written a checkpoint)", aside.string());
    } else {
      put_back(dir, aside);
      spdlog::warn("{}: an interrupted --overwrite had set the earlier run aside before the new run's "
                   "first checkpoint; it is back", dir);
    }
  }
}

}  // namespace handscs
