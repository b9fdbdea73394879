#include "train/run_folder.h"

#include <signal.h>

#include <algorithm>
#include <cerrno>
#include <filesystem>
#include <sstream>

#include <spdlog/spdlog.h>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/text.h"
#include "run/checkpoint.h"

namespace handscs {

namespace fs = std::filesystem;

namespace {
// Cells of one metrics.csv line (its commas plus one).
int64_t count_cells(const std::string& line) { return std::count(line.begin(), line.end(), ',') + 1; }
}  // namespace

bool RunFolderContents::holds_run() const {
  return !checkpoints.empty() || config || metrics || validation || pose_refine;
}

std::string RunFolderContents::describe() const {
  std::vector<std::string> parts;
  if (!checkpoints.empty())
    parts.push_back(std::to_string(checkpoints.size()) + " checkpoint" +
                    (checkpoints.size() > 1 ? "s" : "") + " (newest " +
                    fs::path(checkpoints.front()).filename().string() + ")");
  if (config) parts.push_back("config.json");
  if (metrics) parts.push_back("metrics.csv");
  if (validation) parts.push_back("validation/");
  if (pose_refine) parts.push_back("pose_refine.csv");
  std::string out;
  for (const auto& p : parts) out += (out.empty() ? "" : ", ") + p;
  return out;
}

RunFolderContents inspect_run_folder(const std::string& dir) {
  RunFolderContents c;
  std::error_code ec;
  const fs::path root(dir);
  c.checkpoints = list_checkpoints(dir);
  c.config = fs::exists(root / "config.json", ec);
  c.metrics = fs::exists(root / "metrics.csv", ec);
  c.validation = fs::is_directory(root / "validation", ec);
  c.pose_refine = fs::exists(root / "pose_refine.csv", ec);
  return c;
}

void refuse_run_folder_without_overwrite(const std::string& dir, bool overwrite) {
  const auto contents = inspect_run_folder(dir);
  if (contents.holds_run() && !overwrite)
    throw Error(dir + " holds a run (" + contents.describe() +
                "); continue it with --resume, replace it with --overwrite, or choose another --out");
}

int remove_stale_temporaries(const std::string& dir) {
  int removed = 0;
  for (const auto& folder : {fs::path(dir), fs::path(dir) / "checkpoints"}) {
    std::error_code ec;
    for (const auto& entry : fs::directory_iterator(folder, ec)) {
      const auto name = entry.path().filename().string();
      const auto mark = name.rfind(".tmp.");
      if (mark == std::string::npos) continue;
      const std::string pid_text = name.substr(mark + 5);
      if (pid_text.empty() || !std::all_of(pid_text.begin(), pid_text.end(), ::isdigit)) continue;
      const long pid = std::stol(pid_text);
      // kill(pid, 0) fails with ESRCH only when no such process exists: its writer died.
      if (pid > 0 && kill(static_cast<pid_t>(pid), 0) != 0 && errno == ESRCH) {
        std::error_code remove_error;
        if (fs::remove(entry.path(), remove_error)) ++removed;
      }
    }
  }
  if (removed > 0)
    spdlog::info("{}: removed {} temporary file(s) of an interrupted write", dir, removed);
  return removed;
}

void truncate_metrics_log(const std::string& path, int64_t iteration) {
  std::error_code ec;
  if (!fs::exists(path, ec)) return;
  std::istringstream in(read_file(path));
  std::string line, kept;
  int64_t dropped = 0, cells = -1;
  while (std::getline(in, line)) {
    if (cells < 0) {  // the header
      kept += line + "\n";
      cells = count_cells(line);
      continue;
    }
    if (line.empty()) continue;
    // The first cell is the step count; a torn line (a kill mid-write: too few cells) is dropped.
    int64_t step = -1;
    try {
      size_t used = 0;
      step = std::stoll(line, &used);
      if (line[used] != ',') step = -1;
    } catch (const std::exception&) {
    }
    if (step >= 0 && step <= iteration && count_cells(line) == cells)
      kept += line + "\n";
    else
      ++dropped;
  }
  if (dropped == 0) return;
  write_file_atomic(path, kept);
  spdlog::info("{}: dropped {} row(s) after step {} (logged after the checkpoint resumed from)", path,
               dropped, iteration);
}

std::vector<std::string> prepare_metrics_log(const std::string& path, const std::vector<std::string>& columns) {
  std::error_code ec;
  if (!fs::exists(path, ec)) {
    write_file_atomic(path, join(columns, ",") + "\n");
    return columns;
  }
  std::istringstream in(read_file(path));
  std::string line;
  std::getline(in, line);
  std::vector<std::string> header;
  {
    std::istringstream cells(line);
    std::string cell;
    while (std::getline(cells, cell, ',')) header.push_back(cell);
  }
  std::vector<std::string> added;
  for (const auto& column : columns)
    if (std::find(header.begin(), header.end(), column) == header.end()) added.push_back(column);
  if (added.empty()) return header;

  const auto old_cells = static_cast<int64_t>(header.size());
  header.insert(header.end(), added.begin(), added.end());
  const auto new_cells = static_cast<int64_t>(header.size());
  std::string text = join(header, ",") + "\n";
  int64_t longer = 0;
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    const int64_t cells = count_cells(line);
    if (cells < new_cells && cells >= old_cells) line += std::string(static_cast<size_t>(new_cells - cells), ',');
    if (cells > new_cells) ++longer;
    text += line + "\n";
  }
  write_file_atomic(path, text);
  spdlog::info("{}: header gains {} column(s) ({}) that the earlier run did not log; its rows leave them empty",
               path, added.size(), join(added, ","));
  if (longer > 0)
    spdlog::warn("{}: {} row(s) have more cells than its header; they are left as they are", path, longer);
  return header;
}

}  // namespace handscs
