#include "train/eval_command.h"

#include <cstdio>

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include "core/config.h"
#include "core/error.h"
#include "train/checkpoint.h"
#include "train/evaluate.h"
#include "train/run_config.h"

namespace handscs {

void add_model_eval_options(CLI::App& app, ModelEvalCommandLine& cli) {
  auto* group = app.add_option_group("Model mode", "render a capture's held-out frames with a trained avatar and score them");
  group->add_option("--checkpoint", cli.checkpoint, "checkpoint file, or a run folder (its newest checkpoint)");
  group->add_option("--config", cli.config,
                    "run config naming the capture (default: the config stored in the checkpoint); "
                    "--set overrides its keys, e.g. --set data.root=DIR");
  group->add_option("--out", cli.out, "output folder: summary.json, per_image.csv, table.md");
  group->add_option("--split", cli.split, "frames to score: test (held out) or train")
      ->check(CLI::IsMember({"test", "train"}));
  group->add_flag("--side-by-side", cli.side_by_side,
                  "also write prediction | ground truth | error heat map PNGs");
  group->add_option("--max-images", cli.max_images, "score at most this many frames, evenly spaced over the split (0 = all)");
  group->add_option("--label", cli.label, "column label of table.md (default split/CaptureN)");
}

int run_model_eval_command(const ModelEvalCommandLine& cli, const EvalCommandLine& metric_flags,
                           const std::vector<std::string>& overrides) {
  require(!cli.out.empty(), "model mode needs --out DIR");
  RunConfig config;
  if (!cli.config.empty()) {
    config = load_config<RunConfig>(cli.config, overrides);
  } else {
    const std::string ckpt = resolve_checkpoint_path(cli.checkpoint);
    json stored = load_checkpoint(ckpt).meta.at("config");
    apply_overrides(stored, overrides);
    config_from_json(stored, ckpt + " (stored config)" + (overrides.empty() ? "" : " + --set"), config);
  }
  config.eval = resolve_eval_config(metric_flags, {}, config.eval);
  ModelEvalOptions options;
  options.checkpoint = cli.checkpoint;
  options.out_dir = cli.out;
  options.split = cli.split;
  options.side_by_side = cli.side_by_side;
  options.max_images = cli.max_images;
  options.label = cli.label;
  options.regions = !metric_flags.no_regions;
  options.regions_dir = metric_flags.regions_dir;
  const ModelEvalResult result = evaluate_avatar(config, options);
  std::fputs(format_eval_table(result.report).c_str(), stdout);
  std::printf("rendering: %lld frames, %.1f FPS over the whole forward (median %.1f ms per frame)\n",
              static_cast<long long>(result.frames), result.fps, result.forward_ms);
  std::fflush(stdout);
  spdlog::info("wrote {}/summary.json, per_image.csv and table.md{}", cli.out,
               result.report.regions.empty() ? "" : " (with region scores)");
  return result.report.summary().num_failed == 0 ? 0 : 2;
}

}  // namespace handscs
