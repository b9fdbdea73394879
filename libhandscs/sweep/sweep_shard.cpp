#include "sweep/sweep_shard.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <cstdio>
#include <map>
#include <optional>

#include <nlohmann/json.hpp>

#include "core/atomic_file.h"
#include "core/config.h"
#include "core/error.h"
#include "core/hash.h"
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

ShardRecord shard_record(const SweepConfig& config, const std::vector<std::string>& only_points,
                         const SweepShard& shard) {
  std::string identity = read_file(config.path);
  for (const auto& point : only_points) identity += "\n--points " + point;
  return {config.path, hex16(fnv1a64(identity)), shard};
}

void write_shard_record(const std::string& out_dir, const ShardRecord& record) {
  const nlohmann::json json = {{"sweep", record.sweep},
                               {"fingerprint", record.fingerprint},
                               {"shard", record.shard.index},
                               {"shards", record.shard.count}};
  write_file_atomic(out_dir + "/shard.json", json.dump(2) + "\n");
}

namespace {

// The shard.json of a sweep folder; nullopt when it has none (an older version's folder).
std::optional<ShardRecord> read_shard_record(const std::string& dir) {
  const std::string path = dir + "/shard.json";
  if (!fs::exists(path)) return std::nullopt;
  const nlohmann::json json = load_json_file(path);
  ShardRecord record;
  try {
    record.sweep = json.at("sweep").get<std::string>();
    record.fingerprint = json.at("fingerprint").get<std::string>();
    record.shard = {json.at("shard").get<int>(), json.at("shards").get<int>()};
  } catch (const nlohmann::json::exception& e) {
    throw Error(path + ": not a shard record (" + std::string(e.what()) + ")");
  }
  return record;
}

// Refuses shards of different sweeps, other counts, a shard given twice or one missing.
void check_shard_records(const std::vector<std::string>& dirs) {
  std::vector<std::optional<ShardRecord>> records;
  for (const auto& dir : dirs) records.push_back(read_shard_record(dir));
  const auto with = std::count_if(records.begin(), records.end(), [](const auto& r) { return r.has_value(); });
  if (with == 0) {
    spdlog::warn("merge: no shard folder holds a shard.json (an older handscs-bench wrote them): "
                 "that they are one sweep's complete set of shards is not checked");
    return;
  }
  const ShardRecord* first = nullptr;
  std::string first_dir;
  std::map<int, std::string> given;  // shard index -> folder
  for (size_t k = 0; k < dirs.size(); ++k) {
    if (!records[k])
      throw Error(dirs[k] + "/shard.json: not found, while the other folders have one: is " +
                  dirs[k] + " a shard of this sweep?");
    const ShardRecord& record = *records[k];
    if (!first) {
      first = &record;
      first_dir = dirs[k];
    }
    if (record.fingerprint != first->fingerprint)
      throw Error(dirs[k] + " and " + first_dir + " hold shards of different sweeps (" +
                  record.sweep + ", " + first->sweep + "): merge the shards of one sweep");
    if (record.shard.count != first->shard.count)
      throw Error(dirs[k] + " is shard " + std::to_string(record.shard.index) + " of " +
                  std::to_string(record.shard.count) + ", " + first_dir + " one of " +
                  std::to_string(first->shard.count) + ": merge the shards of one split");
    const auto [it, added] = given.emplace(record.shard.index, dirs[k]);
    if (!added && fs::weakly_canonical(it->second) != fs::weakly_canonical(dirs[k]))
      throw Error(dirs[k] + " and " + it->second + " are both shard " +
                  std::to_string(record.shard.index) + ": were two machines given the same --shard?");
  }
  std::vector<std::string> missing;
  for (int index = 0; index < first->shard.count; ++index)
    if (!given.count(index)) missing.push_back(std::to_string(index));
  if (!missing.empty())
    throw Error("merge: shard" + std::string(missing.size() == 1 ? " " : "s ") + join(missing, ", ") +
                " of " + std::to_string(first->shard.count) +
                " (counted from 0) not given: the table would miss their runs; give every shard's folder");
}

}  // namespace

void merge_sweep_shards(const std::string& out_dir, const std::vector<std::string>& shard_dirs) {
  require(!shard_dirs.empty(), "merge: name the shards' result folders");
  std::error_code ec;
  const auto out_canonical = fs::weakly_canonical(out_dir, ec);
  bool out_is_input = false;
  for (const auto& dir : shard_dirs) out_is_input |= fs::weakly_canonical(dir, ec) == out_canonical;
  if (fs::exists(out_dir + "/results.csv") && !out_is_input)
    throw Error(out_dir + "/results.csv exists and is not one of the shards: merge into a new "
                "folder (nothing is overwritten or mixed without being asked)");

  check_shard_records(shard_dirs);

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
  if (const auto record = read_shard_record(shard_dirs.front()))  // the whole sweep now
    write_shard_record(out_dir, {record->sweep, record->fingerprint, SweepShard{}});
  spdlog::info("merge: {} runs from {} shard folder{} into {}/results.csv", merged.rows.size(),
               shard_dirs.size(), shard_dirs.size() == 1 ? "" : "s", out_dir);
  draw_sweep_plots(out_dir);
}

}  // namespace handscs
