#include "infer/eval_command.h"

#include <cstdio>
#include <utility>

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include "core/config.h"
#include "core/error.h"
#include "core/text.h"
#include "infer/evaluate.h"
#include "run/avatar_state_io.h"
#include "run/run_config.h"

namespace handscs {

namespace {

// Test scores mean something only on images the run never trained on: a config that changes the
// split the run trained with (experiment_differences, the trainer's resume check) is refused.
// Two changes keep that true and stay allowed: data.root (the capture found in another place) and
// a validation split dropped (validation_poses 0, validation_cameras []), which scores the
// capture's own test split, as tools/study/early_stopping.py does. `source` names the config given.
void refuse_changed_split(const TrainedAvatar& trained, const RunConfig& given, const std::string& source) {
  const CaptureConfig& was = trained.trained_config.data;
  RunConfig kept = given;
  kept.data.root = was.root;
  if (kept.data.validation_poses == 0) kept.data.validation_poses = was.validation_poses;
  if (kept.data.validation_cameras.empty()) kept.data.validation_cameras = was.validation_cameras;
  const auto changes = experiment_differences(trained.trained_config, kept);
  if (changes.empty()) return;
  throw Error(source + " changes which images " + trained.path +
              " trained and tests on (checkpoint -> given):\n  " + join(changes, "\n  ") +
              "\nits scores would mix two experiments (training images may score as test images): "
              "evaluate with the run's split (data.root may name the capture's new place)");
}

}  // namespace

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
  // At most 100 million: InterHand2.6M has 2.6 million frames (an unbounded range printed a
  // 309-digit limit for -1).
  group->add_option("--max-images", cli.max_images,
                    "score at most this many frames, evenly spaced over the split (0 = all)")
      ->check(CLI::Range(int64_t{0}, int64_t{100000000}));
  group->add_option("--label", cli.label, "column label of table.md (default split/CaptureN)");
  group->add_flag("--other-capture", cli.other_capture,
                  "score a capture other than the one the checkpoint trained on (refused otherwise: "
                  "data.root must hold the run's capture, copied or moved)");
}

void check_eval_mode_options(const ModelEvalCommandLine& model, const EvalCommandLine& folder) {
  std::vector<std::string> misplaced;
  if (model.model_mode()) {
    for (const auto& [flag, value] : {std::pair<const char*, const std::string*>{"--pred", &folder.folder.pred_dir},
                                      {"--gt", &folder.folder.gt_dir},
                                      {"--mask", &folder.folder.mask_dir},
                                      {"--json", &folder.json_path},
                                      {"--csv", &folder.csv_path}})
      if (!value->empty()) misplaced.push_back(flag);
    if (!misplaced.empty())
      throw Error(join(misplaced, ", ") + ": folder-mode option(s), not used with --checkpoint (model mode "
                  "writes summary.json, per_image.csv and table.md to --out)");
    return;
  }
  const ModelEvalCommandLine defaults;
  if (!model.config.empty()) misplaced.push_back("--config");
  if (!model.out.empty()) misplaced.push_back("--out");
  if (model.split != defaults.split) misplaced.push_back("--split");
  if (model.side_by_side) misplaced.push_back("--side-by-side");
  if (model.max_images != defaults.max_images) misplaced.push_back("--max-images");
  if (!model.label.empty()) misplaced.push_back("--label");
  if (model.other_capture) misplaced.push_back("--other-capture");
  if (folder.no_regions) misplaced.push_back("--no-regions");
  if (!misplaced.empty())
    throw Error(join(misplaced, ", ") + ": model-mode option(s), used only with --checkpoint (folder mode "
                "writes --json and --csv)");
}

int run_model_eval_command(const ModelEvalCommandLine& cli, const EvalCommandLine& metric_flags,
                           const std::vector<std::string>& overrides) {
  require(!cli.out.empty(), "model mode needs --out DIR");
  // A --config or --set mistake is reported before the checkpoint is read.
  refuse_model_overrides(overrides);
  RunConfig config;
  if (!cli.config.empty()) config = load_config<RunConfig>(cli.config, overrides);
  // Without --config the stored config takes the overrides, once, as it is opened.
  const std::vector<std::string> no_overrides;
  TrainedAvatar trained =
      open_trained_avatar(cli.checkpoint, cli.config.empty() ? overrides : no_overrides);
  if (cli.config.empty()) config = trained.config;
  refuse_changed_split(trained, config,
                       cli.config.empty() ? "--set" : cli.config + (overrides.empty() ? "" : " with --set"));
  // A value stored by an older build (training checks it now) is named where it came from.
  check_eval_background(config, cli.config.empty() ? trained.path + " (its stored config)" : cli.config);
  config.eval = resolve_eval_config(metric_flags, {}, config.eval);
  ModelEvalOptions options;
  options.out_dir = cli.out;
  options.split = cli.split;
  options.side_by_side = cli.side_by_side;
  options.max_images = cli.max_images;
  options.label = cli.label;
  options.other_capture = cli.other_capture;
  options.regions = !metric_flags.no_regions;
  options.regions_dir = metric_flags.regions_dir;
  const ModelEvalResult result = evaluate_avatar(config, std::move(trained), options);
  std::fputs(format_eval_table(result.report).c_str(), stdout);
  std::printf("rendering: %lld frames, %.1f FPS over the whole forward (median %.1f ms per frame)\n",
              static_cast<long long>(result.frames), result.fps, result.forward_ms);
  std::printf("colours: %s\n", result.camera_color.c_str());
  std::fflush(stdout);
  spdlog::info("wrote {}/summary.json, per_image.csv and table.md{}", cli.out,
               result.report.regions.empty() ? "" : " (with region scores)");
  return result.report.summary().num_failed == 0 ? 0 : 2;
}

}  // namespace handscs
