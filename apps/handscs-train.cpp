// handscs-train: fits a HandSCS avatar to a capture (InterHand2.6M layout) and writes its run folder.
#include <cstdio>

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include "core/cli.h"
#include "core/config.h"
#include "train/run_config.h"
#include "train/run_folder.h"
#include "train/trainer.h"

int main(int argc, char** argv) {
  CLI::App app{
      "handscs-train: fit a HandSCS hand avatar to a multi-view capture.\n"
      "Writes RUN_DIR/config.json (resolved config), metrics.csv, checkpoints/step_*.ckpt (the\n"
      "newest two), validation/*.png (prediction | ground truth). Ctrl-C saves a checkpoint;\n"
      "--resume continues from the newest valid one. A folder holding another run is refused\n"
      "unless --overwrite. Keys: docs/CONFIG.md; what the tools promise: docs/SAFETY.md."};
  std::string config_path, run_dir;
  bool resume = false, overwrite = false, print_defaults = false, print_docs = false;
  handscs::CommonOptions common;
  app.add_option("--config", config_path, "JSON config (may \"extends\" another; see configs/)");
  app.add_option("--out", run_dir, "run folder for checkpoints, logs and renders");
  app.add_flag("--resume", resume, "continue from RUN_DIR's newest checkpoint (config: RUN_DIR/config.json)");
  app.add_flag("--overwrite", overwrite,
               "replace the run in RUN_DIR (its checkpoints, config.json, metrics.csv, validation/)")
      ->excludes("--resume");
  app.add_flag("--print-defaults", print_defaults, "print the default config as JSON and exit");
  app.add_flag("--print-docs", print_docs, "print every config key as a Markdown table and exit");
  handscs::add_common_options(app, common, true);
  CLI11_PARSE(app, argc, argv);
  try {
    handscs::RunConfig defaults;
    if (print_defaults) {
      std::printf("%s\n", handscs::config_to_json(defaults).dump(2).c_str());
      return 0;
    }
    if (print_docs) {
      std::printf("%s", handscs::config_markdown(defaults).c_str());
      return 0;
    }
    if (run_dir.empty()) throw handscs::Error("--out RUN_DIR is required");
    if (config_path.empty() && resume) config_path = run_dir + "/config.json";
    if (config_path.empty()) throw handscs::Error("--config is required (e.g. configs/demo.json)");
    handscs::start_up(common, "handscs-train");
    const auto config = handscs::load_config<handscs::RunConfig>(config_path, common.overrides);
    handscs::validate_run_config(config, config_path);
    if (!resume) handscs::prepare_fresh_run_folder(run_dir, overwrite);
    handscs::Trainer trainer(config, run_dir);
    if (resume && !trainer.resume()) spdlog::warn("{}: no checkpoint to resume; starting afresh", run_dir);
    const auto summary = trainer.run();
    spdlog::info("{} steps in {:.1f} s, {} Gaussians, {} skipped steps, {} rollbacks", summary.iterations,
                 summary.seconds, summary.gaussians, summary.skipped_steps, summary.rollbacks);
    spdlog::info("checkpoint: {}", summary.checkpoint);
    spdlog::info("evaluate:   handscs-eval --config {} --checkpoint {} --out {}",
                 handscs::shell_quote(config_path), handscs::shell_quote(run_dir),
                 handscs::shell_quote(run_dir + "/eval"));
    return summary.interrupted ? 130 : 0;  // 130: stopped by a signal (shell convention)
  } catch (const std::exception& e) {
    spdlog::error("{}", handscs::error_text(e));
    return 1;
  }
}
