#include "sweep/sweep_runner.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/installed_paths.h"
#include "core/text.h"
#include "core/progress.h"
#include "core/csv_table.h"
#include "sweep/pareto.h"
#include "sweep/results_table.h"
#include "sweep/run_resume.h"
#include "sweep/subprocess.h"

namespace handscs {

namespace fs = std::filesystem;

namespace {

// Step stages logged by the trainer (metrics.csv), reported as medians over the run's second half.
const std::vector<std::string> kStageColumns = {"data_ms", "forward_ms", "losses_ms",
                                                "backward_ms", "optimizer_ms"};
// Debian's Python (with python3-matplotlib), not a PATH python that may lack it.
const char kPython[] = "/usr/bin/python3";
const std::vector<std::string> kRasterColumns = {"gaussians", "threads", "forward_ms",
                                                 "backward_ms", "total_ms", "load_average"};

std::string fixed(double x, int digits) {
  if (!std::isfinite(x)) return "";
  std::ostringstream out;
  out.precision(digits);
  out << std::fixed << x;
  return out.str();
}

double number(const std::string& cell) {
  if (cell.empty()) return std::nan("");
  try {
    return std::stod(cell);
  } catch (const std::exception&) {
    return std::nan("");
  }
}

CsvTable load_or_start(const std::string& path, const std::vector<std::string>& columns) {
  if (!fs::exists(path)) return CsvTable{columns, {}};
  CsvTable table = read_csv(path);
  if (table.header != columns)
    throw Error(path + ": columns differ from this version's (" + join(columns, ",") +
                "); move the file away to start a new sweep");
  return table;
}

// Last data row of a run's metrics.csv (at least one row) by column name, plus "<stage>_median"
// for each step stage over the rows of the second half (after start-up and, usually,
// densification).
std::map<std::string, double> summarise_metrics(const CsvTable& metrics) {
  std::map<std::string, double> row;
  for (size_t c = 0; c < metrics.header.size(); ++c)
    row[metrics.header[c]] = number(metrics.rows.back()[c]);
  const double half = row["iteration"] / 2;
  for (const auto& stage : kStageColumns) {
    if (metrics.column(stage) < 0) continue;
    std::vector<double> values;
    for (size_t r = 0; r < metrics.rows.size(); ++r)
      if (number(metrics.at(r, "iteration")) > half) values.push_back(number(metrics.at(r, stage)));
    if (values.empty()) continue;
    std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
    row[stage + "_median"] = values[values.size() / 2];
  }
  return row;
}

double json_number(const nlohmann::json& object, const char* key) {
  auto it = object.find(key);
  return it != object.end() && it->is_number() ? it->get<double>() : std::nan("");
}

std::string tail_of(const std::string& log_path) {
  std::ifstream in(log_path);
  std::string line, last;
  while (std::getline(in, line))
    if (!line.empty()) last = line;
  return last;
}

// One (point, budget): train, then score. Returns the CSV row (status "ok" or what failed).
std::vector<std::string> run_point(const SweepConfig& config, const SweepOptions& options,
                                   const std::string& capture, const SweepPoint& point,
                                   int budget) {
  const int threads =
      options.threads > 0 ? options.threads : point.threads > 0 ? point.threads : config.threads;
  const std::string run = (fs::path(options.out_dir) / "runs" /
                           (point.name + "_" + std::to_string(budget))).string();
  std::vector<std::string> train = {
      options.bin_dir + "/handscs-train", "--config", config.run_config, "--out", run,
      "--threads", std::to_string(threads), "--set", "data.root=" + capture,
      "--set", "train.iterations=" + std::to_string(budget)};
  if (!options.lpips_weights.empty())
    train.insert(train.end(), {"--set", "eval.lpips.weights=" + options.lpips_weights});
  for (const auto& s : point.set) train.insert(train.end(), {"--set", s});

  std::map<std::string, std::string> cells;
  cells["point"] = point.name;
  cells["budget"] = std::to_string(budget);
  cells["threads"] = std::to_string(threads);
  cells["settings"] = point.set.empty() ? "(run config)" : join(point.set, " ");
  auto finish = [&](const std::string& status) {
    cells["status"] = status;
    std::vector<std::string> row;
    for (const auto& c : result_columns()) row.push_back(cells.count(c) ? cells[c] : "");
    return row;
  };

  // A run stopped half-way by the same command continues from its newest checkpoint
  // (sweep/run_resume.h); anything else in the folder is replaced by a fresh start.
  const std::string identity = sweep_run_identity(train, run, config.run_config);
  bool resuming = sweep_run_resumable(run, identity);
  ProcessResult trained;
  if (resuming) {
    spdlog::info("sweep {}@{}: {} was stopped half-way; continuing it from its newest checkpoint",
                 point.name, budget, run);
    keep_interrupted_log(run);
    std::error_code ec;
    fs::remove_all(run + "/eval", ec);  // a scoring that never finished
    trained = run_process({train.front(), "--resume", "--out", run, "--threads", std::to_string(threads)},
                          run + "/train.log");
    if (trained.exit_code != 0 && checkpoints_refused_in_log(run + "/train.log")) {
      spdlog::warn("sweep {}@{}: none of the stopped run's checkpoints loads ({}); training it afresh",
                   point.name, budget, tail_of(run + "/train.log"));
      resuming = false;
    }
  }
  if (!resuming) {
    fs::remove_all(run);
    ensure_directory(run);
    record_sweep_run(run, identity);
    trained = run_process(train, run + "/train.log");
  }
  const long long resumed_from = resuming ? resumed_step_in_log(run + "/train.log") : -1;
  // A continued run leaves wall time and peak memory empty (sweep/run_resume.h); loop_s, the
  // trainer's own clock, which its checkpoints carry, counts the steps of every attempt.
  if (resumed_from >= 0) {
    cells["resumed_from_step"] = std::to_string(resumed_from);
  } else {
    cells["train_wall_s"] = fixed(trained.wall_seconds, 1);
    cells["peak_rss_mb"] = fixed(trained.peak_rss_mb, 0);
  }
  if (trained.exit_code != 0) {
    spdlog::error("sweep {}@{}: handscs-train exited with {}: {}", point.name, budget,
                  trained.exit_code, tail_of(run + "/train.log"));
    return finish("train failed (" + std::to_string(trained.exit_code) + ")");
  }
  const CsvTable metrics = read_csv(run + "/metrics.csv");
  if (metrics.rows.empty()) {
    // handscs-train logs every train.log_every steps: a budget below it trains without a row.
    spdlog::error("sweep {}@{}: {}/metrics.csv has no rows: a budget of {} steps is below the run "
                  "config's train.log_every; set train.log_every to at most the budget",
                  point.name, budget, run, budget);
    return finish("no step logged");
  }
  auto last = summarise_metrics(metrics);
  for (const auto& stage : kStageColumns)
    if (last.count(stage + "_median")) cells[stage] = fixed(last[stage + "_median"], 2);
  cells["loop_s"] = fixed(last["seconds"], 1);
  cells["ms_per_step"] = fixed(1000.0 * last["seconds"] / std::max(1.0, last["iteration"]), 1);
  cells["gaussians"] = fixed(last["gaussians"], 0);
  cells["skipped_steps"] = fixed(last["skipped"], 0);
  cells["rollbacks"] = fixed(last["rollbacks"], 0);

  const std::string eval_dir = run + "/eval";
  std::vector<std::string> eval = {options.bin_dir + "/handscs-eval", "--checkpoint", run,
                                   "--out", eval_dir, "--threads", std::to_string(threads),
                                   "--max-images", std::to_string(config.eval_images)};
  const ProcessResult scored = run_process(eval, run + "/eval.log");
  cells["eval_wall_s"] = fixed(scored.wall_seconds, 1);
  if (scored.exit_code != 0) {
    spdlog::error("sweep {}@{}: handscs-eval exited with {}: {}", point.name, budget,
                  scored.exit_code, tail_of(run + "/eval.log"));
    return finish("eval failed (" + std::to_string(scored.exit_code) + ")");
  }
  const auto summary = nlohmann::json::parse(read_file(eval_dir + "/summary.json"));
  const auto& s = summary.at("summary");
  cells["eval_images"] = fixed(json_number(s, "scored"), 0);
  cells["psnr"] = fixed(json_number(s, "psnr"), 3);
  cells["ssim"] = fixed(json_number(s, "ssim"), 4);
  cells["lpips"] = fixed(json_number(s, "lpips"), 4);
  if (auto it = summary.find("rendering"); it != summary.end() && it->is_object())
    cells["render_fps"] = fixed(json_number(*it, "fps"), 1);
  if (!options.keep_runs) fs::remove_all(run + "/checkpoints");
  return finish("ok");
}

void run_raster_grid(const SweepConfig& config, const SweepOptions& options) {
  if (config.raster.gaussians.empty()) return;
  const std::string path = options.out_dir + "/raster.csv";
  CsvTable table = load_or_start(path, kRasterColumns);
  ProgressBar bar("raster", static_cast<int64_t>(config.raster.gaussians.size() *
                                                 config.raster.threads.size()));
  int64_t done = 0;
  for (int threads : config.raster.threads) {
    for (int n : config.raster.gaussians) {
      bool have = false;
      for (size_t r = 0; r < table.rows.size(); ++r)
        have |= table.at(r, "gaussians") == std::to_string(n) &&
                table.at(r, "threads") == std::to_string(threads);
      if (!have) {
        const std::string log = options.out_dir + "/logs/raster_" + std::to_string(n) + "_" +
                                std::to_string(threads) + ".json";
        const ProcessResult timed = run_process(
            {options.bin_dir + "/handscs-bench-raster", "--gaussians", std::to_string(n),
             "--threads", std::to_string(threads), "--repeats", std::to_string(config.raster.repeats),
             "--json"},
            log);
        if (timed.exit_code != 0) throw Error(log + ": handscs-bench-raster failed");
        const auto result = nlohmann::json::parse(tail_of(log));
        table.rows.push_back({std::to_string(n), std::to_string(threads),
                              fixed(json_number(result, "forward_ms_median"), 3),
                              fixed(json_number(result, "backward_ms_median"), 3),
                              fixed(json_number(result, "total_ms_median"), 3),
                              fixed(json_number(result, "load_average_1min"), 2)});
        write_csv_atomic(path, table);
      }
      bar.update(++done, std::to_string(n) + " Gaussians, " + std::to_string(threads) + "T");
    }
  }
  bar.finish();
}

}  // namespace

SweepOutcome run_sweep(const SweepConfig& config, const SweepOptions& options) {
  // What every run needs is checked before the first one trains: each would fail the same way.
  std::error_code ec;
  if (!config.run_config.empty() && !fs::is_regular_file(config.run_config, ec))
    throw Error(config.run_config + ": the sweep's run_config is not a file");
  if (!options.capture.empty() && !fs::is_directory(options.capture, ec))
    throw Error(options.capture + ": --capture is not a folder");
  ensure_directory(options.out_dir);
  ensure_directory(options.out_dir + "/logs");
  std::string capture = options.capture;
  if (capture.empty()) {
    capture = fs::absolute(fs::path(options.out_dir) / "capture").string();
    if (!fs::exists(capture + "/annotations")) {
      spdlog::info("sweep: synthesising the `{}` capture into {}", config.capture_preset, capture);
      const auto made = run_process({options.bin_dir + "/handscs-synth", "--preset",
                                     config.capture_preset, "--out", capture},
                                    options.out_dir + "/logs/synth.log");
      if (made.exit_code != 0)
        throw Error(options.out_dir + "/logs/synth.log: handscs-synth failed (exit " +
                    std::to_string(made.exit_code) + ")");
    }
  }

  const std::string results_path = options.out_dir + "/results.csv";
  CsvTable results =
      fs::exists(results_path) ? read_results(results_path) : CsvTable{result_columns(), {}};
  const auto runs = shard_runs(sweep_runs(config, options.only_points), options.shard);
  // What this folder holds, so that a merge can refuse shards of another sweep or a missing one.
  write_shard_record(options.out_dir, shard_record(config, options.only_points, options.shard));
  if (options.shard.count > 1)
    spdlog::info("sweep: shard {} of {} (counted from 0): {} of the sweep's runs", options.shard.index,
                 options.shard.count, runs.size());
  std::vector<std::pair<const SweepPoint*, int>> todo;
  const int64_t total = static_cast<int64_t>(runs.size());
  for (const auto& [point, budget] : runs) {
    bool have = false;
    for (size_t r = 0; r < results.rows.size(); ++r)
      have |= results.at(r, "point") == point->name &&
              results.at(r, "budget") == std::to_string(budget) && results.at(r, "status") == "ok";
    if (!have) todo.push_back({point, budget});
  }
  spdlog::info("sweep: {} runs, {} already in {}, {} to go", total, total - todo.size(),
               results_path, todo.size());
  ProgressBar bar("sweep", total);
  int64_t done = total - static_cast<int64_t>(todo.size());
  bar.update(done);
  for (const auto& [point, budget] : todo) {
    auto row = run_point(config, options, capture, *point, budget);
    // A failed earlier attempt of the same run is replaced, not duplicated.
    auto& rows = results.rows;
    rows.erase(std::remove_if(rows.begin(), rows.end(),
                              [&](const std::vector<std::string>& r) {
                                return r[0] == point->name && r[1] == std::to_string(budget);
                              }),
               rows.end());
    rows.push_back(row);
    write_csv_atomic(results_path, results);
    bar.update(++done, point->name + "@" + std::to_string(budget) + " psnr " + row[13]);
  }
  bar.finish();
  // The rasterizer timings are a property of the machine, not of a run: shard 0 takes them.
  if (options.shard.index == 0) run_raster_grid(config, options);
  draw_sweep_plots(options.out_dir);
  SweepOutcome outcome;
  outcome.runs = static_cast<int>(total);
  for (const auto& [point, budget] : runs)
    for (size_t r = 0; r < results.rows.size(); ++r)
      if (results.at(r, "point") == point->name && results.at(r, "budget") == std::to_string(budget) &&
          results.at(r, "status") != "ok")
        ++outcome.failed;
  return outcome;
}

void draw_sweep_plots(const std::string& out_dir) {
  const std::string results_path = out_dir + "/results.csv";
  std::ostringstream md;
  CsvTable pareto{{"metric", "point", "budget"}, {}};
  if (fs::exists(results_path)) {
    const CsvTable results = read_csv(results_path);  // any table with the columns read below
    // A continued run's start step; "" for other runs and for tables without the column.
    const int resumed_column = results.column("resumed_from_step");
    auto resumed_from = [&](size_t r) -> std::string {
      return resumed_column < 0 ? std::string() : results.rows[r][resumed_column];
    };
    std::map<size_t, std::string> fronts;  // result row -> the fronts it is on, e.g. "PSNR, LPIPS"
    for (const auto& [metric, maximize] :
         std::vector<std::pair<std::string, bool>>{{"psnr", true}, {"lpips", false}}) {
      std::vector<double> all_x, all_y;
      std::vector<size_t> all_rows;  // result row of each (all_x, all_y) point
      for (size_t r = 0; r < results.rows.size(); ++r) {
        if (results.at(r, "status") != "ok") continue;
        all_x.push_back(number(results.at(r, "train_wall_s")));
        all_y.push_back(number(results.at(r, metric)));
        all_rows.push_back(r);
      }
      const std::string metric_name = maximize ? "PSNR" : "LPIPS";
      for (size_t i : pareto_front(all_x, all_y, maximize)) {
        auto& on = fronts[all_rows[i]];
        on += (on.empty() ? "" : ", ") + metric_name;
        pareto.rows.push_back({metric, results.at(all_rows[i], "point"), results.at(all_rows[i], "budget")});
      }
    }
    md << "| point | budget | threads | wall s | ms/step | peak MB | N | skipped | PSNR | SSIM | "
          "LPIPS | Pareto front | settings |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
    bool any_continued = false;
    for (size_t r = 0; r < results.rows.size(); ++r) {
      any_continued |= !resumed_from(r).empty();
      md << "| " << results.at(r, "point") << " | " << results.at(r, "budget") << " | "
         << results.at(r, "threads") << " | "
         << (resumed_from(r).empty() ? results.at(r, "train_wall_s")
                                     : "continued from step " + resumed_from(r))
         << " | "
         << results.at(r, "ms_per_step") << " | " << results.at(r, "peak_rss_mb") << " | "
         << results.at(r, "gaussians") << " | " << results.at(r, "skipped_steps") << " | "
         << results.at(r, "psnr") << " | " << results.at(r, "ssim") << " | "
         << results.at(r, "lpips") << " | " << (fronts.count(r) ? fronts.at(r) : "") << " | "
         << (results.at(r, "status") == "ok" ? results.at(r, "settings")
                                             : results.at(r, "status"))
         << " |\n";
    }
    if (any_continued)
      md << "\nA run continued after a stop has no wall time or peak memory: it is left out of "
            "the Pareto fronts and the time charts (delete its folder and rerun it for them).\n";
  }
  const std::string raster_path = out_dir + "/raster.csv";
  if (fs::exists(raster_path)) {
    const CsvTable raster = read_csv(raster_path);
    md << "\n| N | threads | forward ms | backward ms | total ms |\n|---|---|---|---|---|\n";
    for (size_t r = 0; r < raster.rows.size(); ++r)
      md << "| " << raster.at(r, "gaussians") << " | " << raster.at(r, "threads") << " | "
         << raster.at(r, "forward_ms") << " | " << raster.at(r, "backward_ms") << " | "
         << raster.at(r, "total_ms") << " |\n";
  }
  write_csv_atomic(out_dir + "/pareto.csv", pareto);
  write_file_atomic(out_dir + "/summary.md", md.str());

  // The charts: matplotlib draws them (PNG and vector PDF) from the CSVs. Without Python or
  // matplotlib the tables above are complete and the sweep still succeeds.
  ensure_directory(out_dir + "/logs");
  const std::string log = out_dir + "/logs/plots.log";
  try {
    const std::string script = installed_script("plot_sweep.py");
    spdlog::info("sweep: drawing the charts with {}", script);
    const ProcessResult drawn = run_process({kPython, script, out_dir}, log);
    if (drawn.exit_code != 0)
      spdlog::warn("sweep: charts not drawn ({} exited with {}; see {})", script, drawn.exit_code, log);
  } catch (const Error& e) {
    spdlog::warn("sweep: charts not drawn ({})", e.what());
  }
}

}  // namespace handscs
