#include "metrics/eval_cli.h"

#include <cstdio>

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include "core/config.h"
#include "core/error.h"

namespace handscs {

void add_eval_options(CLI::App& app, EvalCommandLine& cli) {
  auto* folder = app.add_option_group("Folder mode", "score the images of --pred against --gt");
  folder->add_option("--pred", cli.folder.pred_dir, "folder of predicted images");
  folder->add_option("--gt", cli.folder.gt_dir, "folder of ground-truth images (same file names)");
  folder->add_option("--mask", cli.folder.mask_dir,
                     "folder of masks (same file names): ground truth composited onto the background");

  auto* metrics = app.add_option_group("Metrics", "metric conventions (all keys: --set KEY=VALUE)");
  metrics->add_option("--lpips-weights", cli.lpips_weights,
                      "LPIPS weight file (torch.save dict); without it LPIPS is reported as null");
  metrics->add_option("--lpips-net", cli.lpips_net, "LPIPS backbone: alex or vgg");
  metrics->add_option("--lpips-input-range", cli.lpips_input_range,
                      "zero_one (official) or zero_one_unscaled (peers that skip the rescale)");
  metrics->add_option("--ssim", cli.ssim_variant, "SSIM convention: 3dgs, valid or matlab");
  metrics->add_option("--mask-mode", cli.mask_mode, "composite_gt or composite_both");

  auto* regions = app.add_option_group(
      "Regions", "PSNR/SSIM/LPIPS inside region masks too (creases, contact, shadows; docs/METRICS.md)");
  auto* regions_dir = regions->add_option(
      "--regions", cli.regions_dir,
      "region masks and their legend DIR/regions.json. Model mode: masks at "
      "DIR/<split>/<image path>.png; default <capture root>/regions when it holds regions.json. "
      "Folder mode: masks at DIR/<name>.png (no default)");
  regions->add_flag("--no-regions", cli.no_regions,
                    "model mode: do not score regions even when the capture has them")
      ->excludes(regions_dir);

  auto* output = app.add_option_group("Output");
  output->add_option("--json", cli.json_path, "summary and per-image scores (JSON)");
  output->add_option("--csv", cli.csv_path, "per-image scores (CSV)");
}

EvalConfig resolve_eval_config(const EvalCommandLine& cli, const std::vector<std::string>& overrides,
                               const EvalConfig& base) {
  EvalConfig config = base;
  json merged = config_to_json(config);
  // Keys as CONFIG.md spells them in a run config (eval.background) are the same keys here.
  std::vector<std::string> keys;
  for (const auto& text : overrides)
    keys.push_back(text.rfind("eval.", 0) == 0 ? text.substr(5) : text);
  apply_overrides(merged, keys);
  // Flags are set as strings directly (a path such as "123" must not be parsed as a number).
  if (!cli.lpips_weights.empty()) merged["lpips"]["weights"] = cli.lpips_weights;
  if (!cli.lpips_net.empty()) merged["lpips"]["net"] = cli.lpips_net;
  if (!cli.lpips_input_range.empty()) merged["lpips"]["input_range"] = cli.lpips_input_range;
  if (!cli.ssim_variant.empty()) merged["ssim"]["variant"] = cli.ssim_variant;
  if (!cli.mask_mode.empty()) merged["mask_mode"] = cli.mask_mode;
  config_from_json(merged, "command line", config);
  for (double c : config.background)
    require(c >= 0 && c <= 1, "command line: background: values must be in [0, 1]");
  return config;
}

int run_folder_eval_command(const EvalCommandLine& cli, const EvalConfig& config) {
  require(!cli.folder.pred_dir.empty() && !cli.folder.gt_dir.empty(),
          "folder mode needs both --pred DIR and --gt DIR");
  require(!cli.json_path.empty(), "folder mode needs --json FILE for the results");
  FolderEvalInputs inputs = cli.folder;
  inputs.regions_dir = cli.regions_dir;
  const EvalReport report = run_folder_eval(inputs, config);
  write_eval_outputs(report, cli.json_path, cli.csv_path);
  std::fputs(format_eval_table(report).c_str(), stdout);
  std::fflush(stdout);
  spdlog::info("wrote {}{}", cli.json_path, cli.csv_path.empty() ? "" : " and " + cli.csv_path);
  return report.summary().num_failed == 0 ? 0 : 2;
}

}  // namespace handscs
