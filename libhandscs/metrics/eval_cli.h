// handscs-eval's command line: option groups, the EvalConfig they resolve to, and the folder-mode
// run (score, write JSON/CSV atomically, print the table). Model mode adds its own option group
// (infer/eval_command.h) and shares the metric and region options.
#pragma once

#include <string>
#include <vector>

#include "metrics/eval_config.h"
#include "metrics/folder_eval.h"

namespace CLI {
class App;
}

namespace handscs {

struct EvalCommandLine {
  FolderEvalInputs folder;        // --pred, --gt, --mask
  std::string json_path;          // --json (summary and per-image scores)
  std::string csv_path;           // --csv (per-image rows), optional
  // Metric flags; empty = keep the default (or the --set override) of the EvalConfig key.
  std::string lpips_weights;      // --lpips-weights  -> lpips.weights
  std::string lpips_net;          // --lpips-net      -> lpips.net
  std::string lpips_input_range;  // --lpips-input-range -> lpips.input_range
  std::string ssim_variant;       // --ssim           -> ssim.variant
  std::string mask_mode;          // --mask-mode      -> mask_mode
  // Region masks (metrics/region_masks.h); not EvalConfig keys: where they are depends on the mode.
  std::string regions_dir;        // --regions (folder mode: <name>.png; model mode: replaces
                                  // <capture root>/regions)
  bool no_regions = false;        // --no-regions (model mode: skip <capture root>/regions)

  bool folder_mode() const { return !folder.pred_dir.empty() || !folder.gt_dir.empty(); }
};

// Adds the "Folder mode", "Metrics", "Regions" and "Output" option groups.
void add_eval_options(CLI::App& app, EvalCommandLine& cli);

// `base` (the defaults, or a run config's eval section), then the --set overrides, then the metric
// flags; validated (errors name the key, e.g. "command line: ssim.variant: unknown value ...").
EvalConfig resolve_eval_config(const EvalCommandLine& cli, const std::vector<std::string>& overrides,
                               const EvalConfig& base = {});

// Folder mode end to end: checks --pred/--gt/--json, scores (regions too with --regions), writes
// --json (and --csv), prints the table on stdout. Returns the exit status: 0 when every image was scored, 2 when some failed.
int run_folder_eval_command(const EvalCommandLine& cli, const EvalConfig& config);

}  // namespace handscs
