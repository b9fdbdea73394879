// handscs-eval: PSNR / SSIM / LPIPS of predictions against ground truth (docs/METRICS.md).
// Folder mode: --pred DIR --gt DIR [--mask DIR] [--regions DIR] --json FILE.
// Model mode:  --checkpoint CKPT|RUN_DIR [--config CFG] --out DIR (a trained avatar on held-out frames;
//              also inside the capture's region masks when it has regions/regions.json).
#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include "core/cli.h"
#include "core/error.h"
#include "metrics/eval_cli.h"
#include "infer/eval_command.h"

int main(int argc, char** argv) {
  CLI::App app{"handscs-eval: score predictions against ground truth (PSNR, SSIM, LPIPS)"};
  handscs::CommonOptions common;
  handscs::add_common_options(app, common, true);
  handscs::EvalCommandLine cli;
  handscs::add_eval_options(app, cli);
  handscs::ModelEvalCommandLine model;
  handscs::add_model_eval_options(app, model);
  CLI11_PARSE(app, argc, argv);
  try {
    handscs::start_up(common, "handscs-eval");
    handscs::check_eval_mode_options(model, cli);
    if (model.model_mode()) return handscs::run_model_eval_command(model, cli, common.overrides);
    const handscs::EvalConfig config = handscs::resolve_eval_config(cli, common.overrides);
    handscs::require(cli.folder_mode(),
                     "nothing to evaluate: give --pred DIR --gt DIR --json FILE, or --checkpoint CKPT --out DIR");
    return handscs::run_folder_eval_command(cli, config);
  } catch (const std::exception& e) {
    spdlog::error("{}", handscs::error_text(e));
    return 1;
  }
}
