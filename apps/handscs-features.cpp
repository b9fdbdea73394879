// handscs-features: the paper's evidence of structure for one trained avatar (Fig. 1(b), Fig. 7):
// its Gaussians coloured by the principal components of their embeddings, blend transforms vec(T)
// and structural coordinates P in a few poses, and how well each feature set separates the
// phalanges (k-NN accuracy, silhouette), with a t-SNE plot by plot_features.py (share/handscs/scripts/).
//   handscs-features --checkpoint RUN_DIR --out DIR [--poses POSES] [--camera CAM.json] [--threads N]
#include <cstdio>

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include "core/cli.h"
#include "infer/feature_structure.h"

int main(int argc, char** argv) {
  CLI::App app{
      "handscs-features: colour a trained avatar's Gaussians by the first three principal components of their "
      "embeddings, blend transforms vec(T) and structural coordinates P in a few poses (one PCA basis per "
      "representation, fitted on the poses pooled, so colours compare across poses), and measure how well each "
      "feature set separates the phalanges (leave-one-out k-NN accuracy, silhouette)"};
  handscs::CommonOptions common;
  handscs::add_common_options(app, common, false);
  handscs::FeatureStructureOptions options;
  handscs::add_feature_structure_options(app, options);
  app.footer(
      "Compare runs on the same poses and view: run the second with --poses FIRST_OUT/poses.json --camera "
      "FIRST_OUT/camera.json, then run the t-SNE command the first run logged last, with SECOND_OUT for "
      "OTHER_OUT (plot_features.py, in share/handscs/scripts/ beside the programs; docs/FEATURES.md).");
  CLI11_PARSE(app, argc, argv);
  try {
    handscs::start_up(common, "handscs-features");
    const auto result = handscs::run_feature_structure(options);
    std::fputs(handscs::format_feature_scores(result).c_str(), stdout);
    std::fflush(stdout);
    spdlog::info("wrote {} and the features and metrics beside it", result.grid_png);
    if (!result.plot_command.empty()) spdlog::info("t-SNE against another run: {}", result.plot_command);
  } catch (const std::exception& e) {
    spdlog::error("{}", handscs::error_text(e));
    return 1;
  }
  return 0;
}
