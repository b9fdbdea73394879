#include "sweep/sweep_shard.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <map>

#include "core/error.h"
#include "core/text.h"
#include "core/csv_table.h"
#include "sweep/results_table.h"
#include "sweep/sweep_runner.h"

namespace handscs {

namespace fs = std::filesystem;

namespace {

// A whole non-negative decimal number, or -1.
long long whole_number(const std::string& text) {
  if (text.empty() || text.size() > 9 ||
      !std::all_of(text.begin(), text.end(), [](unsigned char c) { return std::isdigit(c); }))
    return -1;
  return std::stoll(text);
}

std::string environment(const char* name) {
  const char* value = std::getenv(name);
  return value ? value : "";
}

}  // namespace

SweepShard parse_sweep_shard(const std::string& text, const std::string& flag) {
  const auto slash = text.find('/');
  const long long index = slash == std::string::npos ? -1 : whole_number(text.substr(0, slash));
  const long long count = slash == std::string::npos ? -1 : whole_number(text.substr(slash + 1));
  if (index < 0 || count < 1 || index >= count)
    throw Error(flag + " " + text + ": expected i/n with 0 <= i < n (shard i of n, counted from 0), "
                "e.g. 0/4");
  return {static_cast<int>(index), static_cast<int>(count)};
}

SweepShard sweep_shard_from_environment() {
  const std::string id = environment("SLURM_ARRAY_TASK_ID"), count = environment("SLURM_ARRAY_TASK_COUNT");
  if (id.empty() && count.empty()) return {};
  const std::string min = environment("SLURM_ARRAY_TASK_MIN");
  const long long task = whole_number(id), tasks = whole_number(count);
  const long long first = min.empty() ? 0 : whole_number(min);
  if (task < 0 || tasks < 1 || first < 0 || task - first < 0 || task - first >= tasks)
    throw Error("SLURM_ARRAY_TASK_ID=" + id + ", SLURM_ARRAY_TASK_MIN=" + min +
                ", SLURM_ARRAY_TASK_COUNT=" + count +
                ": not a shard (expected MIN <= ID < MIN + COUNT); give --shard i/n instead");
  return {static_cast<int>(task - first), static_cast<int>(tasks)};
}

std::vector<std::pair<const SweepPoint*, int>> sweep_runs(const SweepConfig& config,
                                                         const std::vector<std::string>& only_points) {
  for (const auto& name : only_points) {
    bool known = false;
    for (const auto& point : config.points) known |= point.name == name;
    if (!known) throw Error(config.path + ": --points names \"" + name + "\", which is not a point");
  }
  std::vector<std::pair<const SweepPoint*, int>> runs;
  for (const auto& point : config.points) {
    if (!only_points.empty() &&
        std::find(only_points.begin(), only_points.end(), point.name) == only_points.end())
      continue;
    for (int budget : point.budgets.empty() ? config.budgets : point.budgets)
      runs.push_back({&point, budget});
  }
  return runs;
}

std::vector<std::pair<const SweepPoint*, int>> shard_runs(
    const std::vector<std::pair<const SweepPoint*, int>>& runs, const SweepShard& shard) {
  std::vector<std::pair<const SweepPoint*, int>> mine;
  for (size_t k = 0; k < runs.size(); ++k)
    if (static_cast<int>(k % static_cast<size_t>(shard.count)) == shard.index) mine.push_back(runs[k]);
  return mine;
}

void merge_sweep_shards(const std::string& out_dir, const std::vector<std::string>& shard_dirs) {
  require(!shard_dirs.empty(), "merge: name the shards' result folders");
  std::error_code ec;
  const auto out_canonical = fs::weakly_canonical(out_dir, ec);
  bool out_is_input = false;
  for (const auto& dir : shard_dirs) out_is_input |= fs::weakly_canonical(dir, ec) == out_canonical;
  if (fs::exists(out_dir + "/results.csv") && !out_is_input)
    throw Error(out_dir + "/results.csv exists and is not one of the shards: merge into a new "
                "folder (nothing is overwritten or mixed without being asked)");

  // results.csv: one row per (point, budget); "ok" wins over a failed attempt.
  CsvTable merged{result_columns(), {}};
  std::map<std::pair<std::string, std::string>, std::pair<size_t, std::string>> seen;  // -> row, file
  CsvTable raster;
  std::map<std::pair<std::string, std::string>, bool> raster_seen;
  for (const auto& dir : shard_dirs) {
    const std::string path = dir + "/results.csv";
    if (!fs::exists(path)) throw Error(path + ": not found (is " + dir + " a shard's --out folder?)");
    const CsvTable table = read_results(path);  // in this version's columns, whatever wrote it
    for (size_t r = 0; r < table.rows.size(); ++r) {
      const auto key = std::make_pair(table.at(r, "point"), table.at(r, "budget"));
      const bool ok = table.at(r, "status") == "ok";
      auto it = seen.find(key);
      if (it == seen.end()) {
        seen[key] = {merged.rows.size(), path};
        merged.rows.push_back(table.rows[r]);
        continue;
      }
      const bool kept_ok = merged.at(it->second.first, "status") == "ok";
      if (ok && kept_ok)
        throw Error(path + " and " + it->second.second + " both hold a finished run of " + key.first +
                    " at budget " + key.second + ": were two shards given the same --shard?");
      if (ok) {
        merged.rows[it->second.first] = table.rows[r];
        it->second.second = path;
      }
    }
    const std::string raster_path = dir + "/raster.csv";
    if (fs::exists(raster_path)) {
      const CsvTable timings = read_csv(raster_path);
      if (raster.header.empty()) raster.header = timings.header;
      if (timings.header != raster.header)
        throw Error(raster_path + ": its columns differ from the other shards' raster.csv");
      for (size_t r = 0; r < timings.rows.size(); ++r) {
        const auto key = std::make_pair(timings.at(r, "gaussians"), timings.at(r, "threads"));
        if (raster_seen[key]) continue;
        raster_seen[key] = true;
        raster.rows.push_back(timings.rows[r]);
      }
    }
  }
  fs::create_directories(out_dir);
  write_csv_atomic(out_dir + "/results.csv", merged);
  if (!raster.header.empty()) write_csv_atomic(out_dir + "/raster.csv", raster);
  spdlog::info("merge: {} runs from {} shard folder{} into {}/results.csv", merged.rows.size(),
               shard_dirs.size(), shard_dirs.size() == 1 ? "" : "s", out_dir);
  draw_sweep_plots(out_dir);
}

}  // namespace handscs
