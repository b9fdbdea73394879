// How well per-Gaussian features separate anatomical regions, in Euclidean distance (paper §4,
// "Visualization of Deformation Features", made a number):
//   k-NN accuracy: each point gets the label most frequent among its k nearest points (ties: the
//     smallest label, as scikit-learn's KNeighborsClassifier); the share of points labelled right.
//     Leave-one-out: a point's neighbours are the other points of the same set. Transfer: a query
//     point's neighbours are all the points of a reference set (another pose). Balanced: the mean
//     over the labels present of the share of their points labelled right (sklearn's
//     balanced_accuracy_score), so that one large label (the palm's) cannot carry the score.
//   silhouette (Rousseeuw 1987, as sklearn.metrics.silhouette_score): s_i = (b_i - a_i) / max(a_i, b_i),
//     a_i = mean distance to the other points of i's label, b_i = the smallest mean distance to
//     the points of another label; s_i = 0 when i is its label's only point; the mean of s_i.
// Brute force over all pairs (rows in blocks, so memory stays O(block x N)); neighbours are
// ordered by distance, then index, so results do not depend on the thread count.
#pragma once

#include <torch/types.h>

namespace handscs {

struct KnnScore {
  double accuracy = 0;  // share of the points labelled right
  double balanced = 0;  // mean over the labels present of their points' share labelled right
};

KnnScore knn_accuracy_loo(const torch::Tensor& x,       // [N, D]
                          const torch::Tensor& labels,  // [N] int64 >= 0
                          int64_t k);

KnnScore knn_accuracy_transfer(const torch::Tensor& reference,         // [M, D]
                               const torch::Tensor& reference_labels,  // [M] int64 >= 0
                               const torch::Tensor& query,             // [N, D]
                               const torch::Tensor& query_labels,      // [N] int64 >= 0
                               int64_t k);

// Needs 2 <= distinct labels <= N - 1 (as scikit-learn); throws Error otherwise.
double silhouette_score(const torch::Tensor& x,        // [N, D]
                        const torch::Tensor& labels);  // [N] int64 >= 0

}  // namespace handscs
