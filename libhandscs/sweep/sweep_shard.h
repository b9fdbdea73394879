// Sweeps spread over machines: a deterministic share of a sweep's runs per machine (--shard i/n, or
// a Slurm job array), and one merge of the shards' results into the table a single machine writes.
// Run k of the sweep (points in file order, each point's budgets in order; the same enumeration on
// every machine) belongs to shard k mod n, so shards are disjoint, cover the sweep, and balance
// points that repeat over seeds.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "sweep/sweep_config.h"

namespace handscs {

struct SweepShard {
  int index = 0;  // 0-based
  int count = 1;  // 1 = the whole sweep
};

// "i/n" with 0 <= i < n; errors name `flag` and say what is expected.
SweepShard parse_sweep_shard(const std::string& text, const std::string& flag = "--shard");

// The shard of a Slurm job array (SLURM_ARRAY_TASK_ID - SLURM_ARRAY_TASK_MIN of
// SLURM_ARRAY_TASK_COUNT); {0, 1} when those variables are not set.
SweepShard sweep_shard_from_environment();

// Every (point, budget) of the sweep in run order (only `only_points` when not empty).
std::vector<std::pair<const SweepPoint*, int>> sweep_runs(const SweepConfig& config,
                                                         const std::vector<std::string>& only_points);

// The runs of `shard`, in run order.
std::vector<std::pair<const SweepPoint*, int>> shard_runs(
    const std::vector<std::pair<const SweepPoint*, int>>& runs, const SweepShard& shard);

// What a sweep's --out folder holds, written there as shard.json: which sweep (a fingerprint of
// the sweep file's bytes and the --points chosen, and the file's path for messages) and which
// shard. A merge compares the records of its inputs.
struct ShardRecord {
  std::string sweep;        // the sweep file, as given
  std::string fingerprint;  // 16 hex digits
  SweepShard shard;
};
ShardRecord shard_record(const SweepConfig& config, const std::vector<std::string>& only_points,
                         const SweepShard& shard);
void write_shard_record(const std::string& out_dir, const ShardRecord& record);

// Merges the results.csv (and raster.csv, when present) of each shard folder into out_dir, as one
// machine would have written them: every (point, budget) once, an "ok" row preferred over a failed
// attempt; two "ok" rows of the same run, or tables with other columns, are errors naming the files.
// Then redraws the plots and summary.md. Writes atomically; an existing out_dir/results.csv is
// refused unless it is one of the inputs' (merging into a shard folder is allowed). The folders'
// shard.json records must name one sweep, the same shard count, and every shard once (errors name
// the folders and the missing shards); folders of an older version, without records, merge with a
// warning that their completeness is unchecked.
void merge_sweep_shards(const std::string& out_dir, const std::vector<std::string>& shard_dirs);

}  // namespace handscs
