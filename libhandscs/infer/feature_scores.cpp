#include "infer/feature_scores.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "core/csv_table.h"
#include "infer/feature_metrics.h"
#include "infer/feature_pca.h"

namespace handscs {

namespace {

// Summed about the first value, so that equal values (the embeddings' in every pose) give exactly
// that value, and a standard deviation of exactly 0.
double mean_of(const std::vector<double>& v) {
  if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
  double s = 0;
  for (double x : v) s += x - v[0];
  return v[0] + s / double(v.size());
}

// Sample standard deviation (n - 1): three poses are a sample of the poses a hand takes.
double sd_of(const std::vector<double>& v) {
  if (v.size() < 2) return 0;
  const double m = mean_of(v);
  double sq = 0;
  for (double x : v) sq += (x - m) * (x - m);
  return std::sqrt(sq / double(v.size() - 1));
}

json summary_json(const std::vector<double>& values) {
  return {{"per_pose", values},
          {"mean", mean_of(values)},
          {"std", sd_of(values)},
          {"min", *std::min_element(values.begin(), values.end())},
          {"max", *std::max_element(values.begin(), values.end())}};
}

json number_or_null(double x) { return std::isfinite(x) ? json(x) : json(nullptr); }

}  // namespace

std::vector<FeatureScore> score_feature_sets(const std::vector<GaussianFeatures>& poses, int64_t k) {
  require(!poses.empty(), "score_feature_sets: no poses");
  const auto& labels = poses.front().labels;
  std::vector<FeatureScore> scores;
  for (FeatureSet set : kFeatureSets) {
    std::vector<torch::Tensor> raw;
    for (const auto& f : poses) raw.push_back(f.get(set));
    if (raw.front().size(1) == 0) continue;
    const Standardizer standardizer = fit_standardizer(torch::cat(raw, 0));
    std::vector<torch::Tensor> z;
    for (const auto& x : raw) z.push_back(standardizer.apply(x));
    FeatureScore score;
    score.set = feature_set_name(set);
    score.dims = raw.front().size(1);
    for (const auto& x : z) {
      const KnnScore knn = knn_accuracy_loo(x, labels, k);
      score.knn.push_back(knn.accuracy);
      score.knn_balanced.push_back(knn.balanced);
      score.silhouette.push_back(silhouette_score(x, labels));
    }
    std::vector<double> transfer, transfer_balanced;
    for (size_t a = 0; a < z.size(); ++a)
      for (size_t b = 0; b < z.size(); ++b) {
        if (a == b) continue;
        const KnnScore knn = knn_accuracy_transfer(z[a], labels, z[b], labels, k);
        transfer.push_back(knn.accuracy);
        transfer_balanced.push_back(knn.balanced);
      }
    score.knn_transfer = mean_of(transfer);
    score.knn_transfer_balanced = mean_of(transfer_balanced);
    scores.push_back(score);
  }
  return scores;
}

json feature_score_json(const FeatureScore& s) {
  return {{"dims", s.dims},
          {"knn_accuracy", summary_json(s.knn)},
          {"knn_balanced_accuracy", summary_json(s.knn_balanced)},
          {"silhouette", summary_json(s.silhouette)},
          {"knn_transfer", number_or_null(s.knn_transfer)},
          {"knn_transfer_balanced", number_or_null(s.knn_transfer_balanced)}};
}

std::string feature_scores_per_pose_csv(const std::string& run, const std::vector<std::string>& poses,
                                        const std::vector<FeatureScore>& scores) {
  std::string text = std::string(kFeatureScoresPerPoseHeader) + "\n";
  char line[512];
  for (const auto& s : scores)
    for (size_t p = 0; p < s.knn.size(); ++p) {
      std::snprintf(line, sizeof(line), "%s,%s,%lld,%s,%.6f,%.6f,%.6f\n", csv_cell(run).c_str(), s.set.c_str(),
                    static_cast<long long>(s.dims), csv_cell(poses.at(p)).c_str(), s.knn[p], s.knn_balanced[p],
                    s.silhouette[p]);
      text += line;
    }
  return text;
}

std::string feature_scores_summary_csv(const std::string& run, const std::vector<FeatureScore>& scores,
                                       int64_t gaussians, double majority_share) {
  std::string text =
      "run,set,dims,knn_mean,knn_sd,knn_balanced_mean,knn_balanced_sd,silhouette_mean,silhouette_sd,"
      "knn_transfer,knn_transfer_balanced,gaussians,majority_share\n";
  char line[512];
  for (const auto& s : scores) {
    std::snprintf(line, sizeof(line), "%s,%s,%lld,%.6f,%.6f,%.6f,%.6f,%.6f,%.6f,%.6f,%.6f,%lld,%.6f\n",
                  csv_cell(run).c_str(), s.set.c_str(), static_cast<long long>(s.dims), mean_of(s.knn),
                  sd_of(s.knn), mean_of(s.knn_balanced), sd_of(s.knn_balanced), mean_of(s.silhouette),
                  sd_of(s.silhouette), s.knn_transfer, s.knn_transfer_balanced,
                  static_cast<long long>(gaussians), majority_share);
    text += line;
  }
  return text;
}

std::string format_feature_score_table(const std::vector<FeatureScore>& scores) {
  char line[512];
  std::snprintf(line, sizeof(line), "%-18s %5s  %-14s %-14s %-15s %s\n", "set", "dims", "kNN acc (sd)",
                "balanced (sd)", "silhouette (sd)", "kNN across poses (balanced)");
  std::string text = line;
  for (const auto& s : scores) {
    std::snprintf(line, sizeof(line), "%-18s %5lld  %.3f (%.3f)  %.3f (%.3f)  %+.3f (%.3f)  %.3f (%.3f)\n",
                  s.set.c_str(), static_cast<long long>(s.dims), mean_of(s.knn), sd_of(s.knn),
                  mean_of(s.knn_balanced), sd_of(s.knn_balanced), mean_of(s.silhouette), sd_of(s.silhouette),
                  s.knn_transfer, s.knn_transfer_balanced);
    text += line;
  }
  return text;
}

}  // namespace handscs
