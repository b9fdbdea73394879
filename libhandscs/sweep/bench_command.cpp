#include "sweep/bench_command.h"

#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>

#include "core/cli.h"
#include "core/error.h"
#include "core/installed_paths.h"
#include "core/logging.h"
#include "sweep/sweep_config.h"
#include "sweep/sweep_runner.h"
#include "sweep/sweep_shard.h"

namespace handscs {

int bench_command(int argc, char** argv) {
  CLI::App app{
      "handscs-bench: run time against error. Trains and evaluates each point of a sweep file at\n"
      "each training budget (handscs-train, handscs-eval as child processes: wall time, ms/step,\n"
      "peak memory, Gaussians, novel-pose PSNR/SSIM/LPIPS), times the rasterizer over N, and\n"
      "writes OUT/results.csv, OUT/raster.csv, OUT/summary.md and OUT/*.png. Rerunning with the\n"
      "same OUT resumes: finished rows are kept, and a run stopped half-way continues from its\n"
      "newest checkpoint if the same command, run config and handscs-train binary began it (its\n"
      "row: resumed_from_step, no wall time or peak memory). On several machines: --shard i/n\n"
      "(or a Slurm job array) on each, then --merge DIR1,DIR2,... --out OUT (docs/BENCHMARKS.md,\n"
      "\"Sweeps on a cluster\"). Exits with 3 when a run failed (its row says why; the others are\n"
      "kept)."};
  std::string sweep_path;
  SweepOptions options;
  CommonOptions common;
  bool plots_only = false;
  app.add_option("--sweep", sweep_path,
                 "sweep file, e.g. configs/sweeps/quick.json (installed: share/handscs/configs/sweeps/)")
      ->check(CLI::ExistingFile);
  app.add_option("--out", options.out_dir, "results folder (resumed if it holds results)")
      ->required();
  app.add_option("--capture", options.capture,
                 "capture root (default: OUT/capture, synthesised from the sweep's preset)");
  app.add_option("--lpips-weights", options.lpips_weights,
                 "LPIPS weights (loss and metric); without them LPIPS is neither trained nor "
                 "reported");
  app.add_option("--points", options.only_points,
                 "run only these points of the sweep (e.g. to run two in parallel into two OUTs)")
      ->delimiter(',');
  std::string shard;
  app.add_option("--shard", shard,
                 "run only shard i of n (i/n, counted from 0): run k of the sweep belongs to shard "
                 "k mod n; without it, a Slurm job array's SLURM_ARRAY_TASK_* variables choose it");
  std::vector<std::string> merge_dirs;
  app.add_option("--merge", merge_dirs,
                 "merge these shards' --out folders into OUT (results.csv, raster.csv, plots, "
                 "summary.md) and stop")
      ->delimiter(',');
  app.add_flag("--keep-runs", options.keep_runs, "keep each run's checkpoints after scoring");
  app.add_flag("--plots-only", plots_only, "redraw plots and summary.md from OUT's CSVs");
  add_common_options(app, common, false);
  app.get_option("--threads")
      ->description("threads of every training and evaluation run (default: the sweep file's "
                    "threads, and each point's own)");
  CLI11_PARSE(app, argc, argv);
  try {
    // The sweep's children get their threads on their command lines: this process only waits.
    options.threads = common.threads;
    set_log_level(common.log_level);
    if (plots_only) {
      draw_sweep_plots(options.out_dir);
      return 0;
    }
    if (!merge_dirs.empty()) {
      merge_sweep_shards(options.out_dir, merge_dirs);
      return 0;
    }
    if (sweep_path.empty()) throw Error("--sweep is required (or --plots-only, --merge)");
    options.shard = shard.empty() ? sweep_shard_from_environment() : parse_sweep_shard(shard);
    options.bin_dir = executable_dir();
    const SweepOutcome outcome = run_sweep(load_sweep_config(sweep_path), options);
    spdlog::info("handscs-bench: results in {}/results.csv, charts {}/*.png and *.pdf, table {}/summary.md",
                 options.out_dir, options.out_dir, options.out_dir);
    if (outcome.failed > 0) {
      spdlog::error("handscs-bench: {} of {} runs failed (status column of {}/results.csv; logs in "
                    "{}/runs/*/)",
                    outcome.failed, outcome.runs, options.out_dir, options.out_dir);
      return 3;
    }
  } catch (const std::exception& e) {
    spdlog::error("{}", error_text(e));
    return 1;
  }
  return 0;
}

}  // namespace handscs
