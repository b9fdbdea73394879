// handscs-eval's model mode on the command line: --checkpoint (file or run folder) [--config CFG]
// --out DIR; the metric flags of folder mode apply to the run config's eval section.
#pragma once

#include <string>
#include <vector>

#include "metrics/eval_cli.h"

namespace CLI {
class App;
}

namespace handscs {

struct ModelEvalCommandLine {
  std::string config;      // run config (default: the checkpoint's own)
  std::string checkpoint;  // checkpoint file or run folder
  std::string out;         // output folder
  std::string split = "test";
  bool side_by_side = false;
  int64_t max_images = 0;
  std::string label;
  bool other_capture = false;

  bool model_mode() const { return !checkpoint.empty(); }
};

// Adds the "Model mode" option group.
void add_model_eval_options(CLI::App& app, ModelEvalCommandLine& cli);

// Throws Error naming the options given that the chosen mode cannot use (folder options with
// --checkpoint, model options without it): an option that would be ignored is an error.
void check_eval_mode_options(const ModelEvalCommandLine& model, const EvalCommandLine& folder);

// Model mode end to end: resolves the config (--config or the checkpoint's, then --set on run-config
// keys, then the metric flags; --set model.* is refused, as evaluate_avatar always uses the
// checkpoint's model section), refuses one that changes the split the run trained with (data.root
// and dropping a validation split aside), evaluates, writes the outputs, prints the table. Exit
// status: 0 when every image was scored, 2 when some failed.
int run_model_eval_command(const ModelEvalCommandLine& cli, const EvalCommandLine& metric_flags,
                           const std::vector<std::string>& overrides);

}  // namespace handscs
