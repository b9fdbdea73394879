// Runs a speed-accuracy sweep: for every (point, budget) it trains with handscs-train, scores the
// held-out poses with handscs-eval, and records wall time, ms per step, peak memory, Gaussian count
// and PSNR/SSIM/LPIPS as one CSV row; then times the rasterizer alone over N and threads, and draws
// the charts. Rows already in the CSV are kept, so a stopped sweep resumes where it stopped, and a
// run stopped half-way continues from its newest checkpoint (sweep/run_resume.h).
#pragma once

#include <string>
#include <vector>

#include "sweep/sweep_config.h"
#include "sweep/sweep_shard.h"

namespace handscs {

struct SweepOptions {
  std::string out_dir;        // results.csv, raster.csv, *.png, summary.md, runs/, logs/
  std::string capture;        // capture root; empty = out_dir/capture, synthesised when missing
  std::string bin_dir;        // folder of handscs-train, -eval, -synth, -bench-raster
  std::string lpips_weights;  // LPIPS weights for the loss and the metric (empty = none)
  bool keep_runs = false;     // keep each run's checkpoints (they are deleted once scored)
  std::vector<std::string> only_points;  // run only these points (empty = all)
  SweepShard shard;           // this machine's share of the runs (sweep/sweep_shard.h)
  int threads = 0;            // threads of every run (0 = the sweep file's, and each point's own)
};

struct SweepOutcome {
  int runs = 0;    // runs of this sweep (or shard)
  int failed = 0;  // of those, runs whose row is not "ok" (kept in results.csv with the reason)
};

SweepOutcome run_sweep(const SweepConfig& config, const SweepOptions& options);

// Rewrites summary.md and pareto.csv from the CSVs in out_dir (no training) and has
// scripts/plot_sweep.py (matplotlib) draw the charts as PNG and PDF; without Python or matplotlib
// the charts are skipped with a warning. summary.md marks each
// row on the PSNR or LPIPS Pareto front (against training wall time, over all points).
void draw_sweep_plots(const std::string& out_dir);

}  // namespace handscs
