// How well each feature set (infer/feature_sets.h) separates the phalange labels over a few poses,
// with the metrics of infer/feature_metrics.h: per pose, and across poses (one pose's Gaussians
// classified among another's). Each set's columns are standardised once, over the poses pooled,
// so every pose is measured in one space. Plus the tables handscs-features writes and prints.
#pragma once

#include <string>
#include <vector>

#include "core/config.h"
#include "infer/feature_sets.h"

namespace handscs {

struct FeatureScore {
  std::string set;  // feature_set_name()
  int64_t dims = 0;
  std::vector<double> knn, knn_balanced, silhouette;  // per pose
  // Mean over the ordered pose pairs (a, b), a != b, of the k-NN accuracy of b's Gaussians among
  // a's (NaN with one pose). Features that do not change with the pose score their
  // leave-one-out value with each point's own copy among its neighbours.
  double knn_transfer = 0, knn_transfer_balanced = 0;
};

// One score per feature set with columns (a model without embeddings has no "embedding" score);
// every pose's features come from one avatar (the same Gaussians and labels).
std::vector<FeatureScore> score_feature_sets(const std::vector<GaussianFeatures>& poses, int64_t k);

// {"dims", "knn_accuracy", "knn_balanced_accuracy", "silhouette" (each {"per_pose", "mean", "std"
// (sample, n - 1), "min", "max"}), "knn_transfer", "knn_transfer_balanced"}.
json feature_score_json(const FeatureScore& score);

// metrics.csv's header line (without its line break).
constexpr char kFeatureScoresPerPoseHeader[] = "run,set,dims,pose,knn_accuracy,knn_balanced_accuracy,silhouette";
// metrics.csv: run, set, dims, pose, knn_accuracy, knn_balanced_accuracy, silhouette.
std::string feature_scores_per_pose_csv(const std::string& run, const std::vector<std::string>& poses,
                                        const std::vector<FeatureScore>& scores);
// metrics_summary.csv: per set the means and sample standard deviations over the poses, the
// cross-pose accuracies, the Gaussian count and the largest label's share.
std::string feature_scores_summary_csv(const std::string& run, const std::vector<FeatureScore>& scores,
                                       int64_t gaussians, double majority_share);
// A plain-text table for the terminal.
std::string format_feature_score_table(const std::vector<FeatureScore>& scores);

}  // namespace handscs
