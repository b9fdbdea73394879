// handscs-features: the paper's evidence of structure (Fig. 1(b), Fig. 7), reproduced and measured
// for one trained avatar. In a few poses it colours the Gaussians by the first three principal
// components of each representation (embeddings, vec(T), P; the basis and colour range fitted once
// on the poses pooled), renders them from one camera into a labelled grid, scores how well each
// feature set separates the phalanges (k-NN accuracy, silhouette; infer/feature_metrics.h), and
// writes the features for scripts/plot_features.py (t-SNE plots, scikit-learn cross-check).
#pragma once

#include <string>
#include <vector>

#include "infer/feature_scores.h"

namespace CLI {
class App;
}

namespace handscs {

struct FeatureStructureOptions {
  std::string checkpoint;  // checkpoint file, or a run folder (its newest checkpoint)
  std::string poses;       // POSES file (infer/pose_source.h); "" = held-out poses of the run's capture
  int num_poses = 3;       // held-out poses taken, evenly spaced, without --poses (the paper's figure shows three)
  std::string camera;      // camera JSON; "" = the capture camera in which the first pose's hand is
                           // largest (an orbit view when the POSES file carries no cameras)
  std::string out_dir;     // pca_grid.png, features.csv/.json, metrics.csv/.json, poses.json, camera.json
  std::string label;       // the run's name in files and plots ("" = "SCS" or "no SCS", from its config)
  int knn_k = 10;          // neighbours of the k-NN accuracy (10: a few per label among ~3k Gaussians
                           // in 16 labels, so a vote reflects a neighbourhood, not one nearest point)
  // Colours span the p-th to (100 - p)-th percentile of each component: with min-max, the few
  // Gaussians far out (fresh densification clones, spikes) would squeeze all others into one colour.
  double colour_percentile = 1.0;
  bool plot = true;        // run scripts/plot_features.py: this run's t-SNE and the scikit-learn check
};

// Adds the options above (with --help text) to `app`.
void add_feature_structure_options(CLI::App& app, FeatureStructureOptions& options);

struct FeatureStructureResult {
  std::string label;
  std::vector<std::string> poses;
  int64_t gaussians = 0;
  double majority_share = 0;  // share of the largest label: what always guessing it scores
  std::vector<FeatureScore> scores;
  std::string grid_png;
  std::string plot_command;  // how to draw the t-SNE comparison of this run with others ("" without the script)
};

// handscs-features writes metrics.csv, the name of a training run's log: throws Error when
// `out_dir` holds a run (config.json, checkpoints) or a metrics.csv it did not write, so nothing
// trained is replaced (nor becomes the log a later --resume appends to). Nothing is read but the
// folder's entries and that file's first line.
void refuse_out_holding_training_files(const std::string& out_dir);

// The whole command (refuse_out_holding_training_files first); writes everything into
// options.out_dir. Throws Error naming the file or option at fault.
FeatureStructureResult run_feature_structure(const FeatureStructureOptions& options);

// The result as a plain-text table for the terminal (means and spreads over the poses).
std::string format_feature_scores(const FeatureStructureResult& result);

}  // namespace handscs
