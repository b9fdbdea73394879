#include "train/train_command.h"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include "core/available_memory.h"
#include "core/cli.h"
#include "core/config.h"
#include "core/text.h"
#include "run/run_config.h"
#include "train/data_parallel.h"
#include "train/out_of_memory.h"
#include "train/run_folder.h"
#include "train/set_aside_run.h"
#include "train/trainer.h"

namespace handscs {

int train_command(int argc, char** argv) {
  CLI::App app{
      "handscs-train: fit a HandSCS hand avatar to a multi-view capture.\n"
      "Writes RUN_DIR/config.json (resolved config), metrics.csv, checkpoints/step_*.ckpt (the\n"
      "newest two), validation/*.png (render | truth | error, labelled). Ctrl-C saves a checkpoint;\n"
      "--resume continues from the newest valid one. A folder holding another run is refused\n"
      "unless --overwrite. Keys: docs/CONFIG.md; what the tools promise: docs/SAFETY.md.\n"
      "Several processes (one machine or many) train one avatar data-parallel: start each with\n"
      "RANK, WORLD_SIZE, MASTER_ADDR, MASTER_PORT in the environment (as torchrun sets them) or\n"
      "the --rank/--world-size/--master-* flags; rank 0 takes --config, writes RUN_DIR and\n"
      "resumes; the others need only --out (their mask cache). README: \"Training on several\n"
      "machines\"."};
  std::string config_path, run_dir;
  bool resume = false, overwrite = false, print_defaults = false, print_docs = false;
  bool resume_changing_data = false;
  CommonOptions common;
  app.add_option("--config", config_path, "JSON config (may \"extends\" another; see configs/)");
  app.add_option("--out", run_dir, "run folder for checkpoints, logs and renders");
  app.add_flag("--resume", resume, "continue from RUN_DIR's newest checkpoint (config: RUN_DIR/config.json)");
  app.add_flag("--overwrite", overwrite,
               "replace the run in RUN_DIR (its checkpoints, config.json, metrics.csv, validation/)")
      ->excludes("--resume");
  app.add_flag("--resume-changing-data", resume_changing_data,
               "with --resume: accept a config that changes which images train and test (capture, "
               "split, held-out poses, cameras; refused otherwise, as its scores would mix two "
               "experiments)")
      ->needs("--resume");
  app.add_flag("--print-defaults", print_defaults, "print the default config as JSON and exit");
  app.add_flag("--print-docs", print_docs, "print every config key as a Markdown table and exit");
  add_common_options(app, common, true);
  auto parallel = data_parallel_from_environment();
  app.add_option("--rank", parallel.rank, "this process's rank, 0 .. world size - 1 (env RANK)");
  app.add_option("--world-size", parallel.world_size,
                 "number of data-parallel processes (env WORLD_SIZE; 1 = no rendezvous)");
  app.add_option("--master-addr", parallel.master_addr, "rank 0's host (env MASTER_ADDR)");
  app.add_option("--master-port", parallel.master_port, "rank 0's rendezvous port (env MASTER_PORT)");
  app.add_option("--dist-timeout", parallel.timeout_s,
                 "seconds any rank waits for the others (rendezvous, each exchange) before failing")
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  try {
    RunConfig defaults;
    if (print_defaults) {
      std::printf("%s\n", config_to_json(defaults).dump(2).c_str());
      return 0;
    }
    if (print_docs) {
      std::printf("%s", config_markdown(defaults).c_str());
      return 0;
    }
    if (run_dir.empty()) throw Error("--out RUN_DIR is required");
    validate_data_parallel(parallel);
    const bool root = parallel.rank == 0;
    if (config_path.empty() && resume) config_path = run_dir + "/config.json";
    if (config_path.empty() && root)
      throw Error("--config is required (e.g. configs/demo.json)");
    start_up(common, "handscs-train");
    std::unique_ptr<ProcessGroup> group;
    if (parallel.world_size > 1) {
      group = std::make_unique<ProcessGroup>(parallel);
      spdlog::info("data parallel: rank {} of {} (rendezvous at {}:{})", parallel.rank,
                   parallel.world_size, parallel.master_addr, parallel.master_port);
    }
    // An earlier run a killed --overwrite set aside is put back first, before a resume reads the
    // folder's config.json (the killed run's otherwise, not the run resumed).
    if (root && std::filesystem::is_directory(run_dir)) recover_set_aside_runs(run_dir);
    RunConfig config;
    std::string config_text;
    if (root) {
      config = load_config<RunConfig>(config_path, common.overrides);
      validate_run_config(config, config_path);
      config_text = config_to_json(config).dump();
    }
    if (group) {
      // Every rank trains with rank 0's config: one source of truth for all settings.
      group->broadcast_bytes(config_text);
      if (!root)
        config_from_json(nlohmann::json::parse(config_text), "rank 0's config", config);
    }
    // A fresh run into a folder holding another is refused before anything else happens...
    if (root && !resume) refuse_run_folder_without_overwrite(run_dir, overwrite);
    // ...and with --overwrite the old run is set aside only once the new one has opened its
    // capture and passed the trainer's checks, and deleted once the new one has its first
    // checkpoint; a new run that ends before that removes its own files and puts the old back.
    Trainer trainer(config, run_dir, group.get());
    // A run this machine cannot hold is refused before the folder changes (a resume's after its
    // checkpoint gave the Gaussian count). Each rank checks its own process.
    const auto check_memory = [&] {
      const TrainMemoryEstimate estimate = trainer.memory_estimate();
      const int64_t available = available_memory_bytes();
      check_train_memory(estimate, available);
      if (root)
        spdlog::info("memory: {}; {} available", train_memory_text(estimate),
                     available < 0 ? std::string("not known") : bytes_text(static_cast<double>(available)));
    };
    if (!resume) check_memory();
    std::optional<SetAsideRun> folder_guard;
    if (root && !resume) {
      folder_guard.emplace(run_dir);
      trainer.on_first_checkpoint([&folder_guard] { folder_guard->discard(); });
    }
    if (root && resume && !trainer.resume(resume_changing_data))
      spdlog::warn("{}: no checkpoint to resume; starting afresh", run_dir);
    if (resume) check_memory();
    const auto summary = trainer.run();
    if (summary.steps == 0)
      spdlog::info("{}: already at step {} of train.iterations = {}: nothing to train (raise "
                   "train.iterations to continue)",
                   run_dir, summary.iterations, config.train.iterations);
    else
      spdlog::info("{} steps in {:.1f} s ({:.2f} views/s), {} Gaussians, {} skipped steps, {} rollbacks",
                   summary.iterations, summary.seconds,
                   summary.seconds > 0 ? summary.views / summary.seconds : 0.0, summary.gaussians,
                   summary.skipped_steps, summary.rollbacks);
    if (group && summary.communication.calls > 0) {
      const double steps = std::max<double>(1.0, static_cast<double>(summary.steps));
      spdlog::info("data parallel: {:.2f} MB exchanged per step, {:.1f} ms per step in the "
                   "collectives (waiting for the slowest rank included)",
                   summary.communication.bytes / steps / 1e6,
                   summary.communication.seconds / steps * 1e3);
    }
    if (!root) return summary.interrupted ? 130 : 0;
    spdlog::info("checkpoint: {}", summary.checkpoint);
    // No --config: the checkpoint stores the config trained with, --set overrides applied, where
    // the config file alone lacks them (no data.root) and model.* ones would be refused.
    spdlog::info("evaluate:   handscs-eval --checkpoint {} --out {}", shell_quote(run_dir),
                 shell_quote(run_dir + "/eval"));
    return summary.interrupted ? 130 : 0;  // 130: stopped by a signal (shell convention)
  } catch (const std::exception& e) {
    // Opening the capture, building the model or resuming can run out of memory too (the trainer's
    // own steps, checkpoints and validation name it themselves).
    if (is_out_of_memory(e))
      spdlog::error("{}", out_of_memory_error(e, "while opening the run", -1).what());
    else
      spdlog::error("{}", error_text(e));
    return 1;
  }
}

}  // namespace handscs
