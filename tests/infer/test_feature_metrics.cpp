// k-NN accuracy and silhouette (infer/feature_metrics.h): constructed cases worked by hand, and
// random clustered data against plain-loop references (every pair, full sort) written here.
#include "catch_torch.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "core/error.h"
#include "infer/feature_metrics.h"
#include "test_support.h"

namespace {

torch::Tensor points_1d(const std::vector<double>& x) {
  return torch::tensor(x, torch::kFloat64).unsqueeze(1);
}
torch::Tensor label_tensor(const std::vector<int64_t>& l) { return torch::tensor(l, torch::kLong); }

double distance(const torch::Tensor& x, int64_t i, const torch::Tensor& y, int64_t j) {
  const auto a = x.accessor<double, 2>();
  const auto b = y.accessor<double, 2>();
  double s = 0;
  for (int64_t c = 0; c < x.size(1); ++c) {
    const double d = a[i][c] - b[j][c];
    s += d * d;
  }
  return std::sqrt(s);
}

// Plain k-NN: every distance, a full sort by (distance, index), a count per label; returns the
// accuracy and the balanced accuracy.
std::pair<double, double> reference_knn(const torch::Tensor& ref, const std::vector<int64_t>& ref_labels, const torch::Tensor& query,
                     const std::vector<int64_t>& query_labels, int64_t k, bool leave_one_out) {
  int64_t right = 0;
  std::vector<double> seen(16, 0), hits(16, 0);
  for (int64_t i = 0; i < query.size(0); ++i) {
    std::vector<std::pair<double, int64_t>> all;
    for (int64_t j = 0; j < ref.size(0); ++j)
      if (!(leave_one_out && i == j)) all.push_back({distance(query, i, ref, j), j});
    std::sort(all.begin(), all.end());
    std::vector<int64_t> votes(16, 0);
    for (int64_t n = 0; n < k; ++n) ++votes[ref_labels[all[n].second]];
    int64_t best = 0;
    for (int64_t c = 1; c < 16; ++c)
      if (votes[c] > votes[best]) best = c;
    right += best == query_labels[i];
    seen[query_labels[i]] += 1;
    hits[query_labels[i]] += best == query_labels[i];
  }
  double balanced = 0, present = 0;
  for (int64_t c = 0; c < 16; ++c)
    if (seen[c] > 0) {
      balanced += hits[c] / seen[c];
      present += 1;
    }
  return {double(right) / double(query.size(0)), balanced / present};
}

// Plain silhouette, straight from the definition.
double reference_silhouette(const torch::Tensor& x, const std::vector<int64_t>& l) {
  const int64_t n = x.size(0);
  double total = 0;
  for (int64_t i = 0; i < n; ++i) {
    std::vector<double> sum(16, 0);
    std::vector<int64_t> count(16, 0);
    for (int64_t j = 0; j < n; ++j) {
      if (j == i) continue;
      sum[l[j]] += distance(x, i, x, j);
      ++count[l[j]];
    }
    if (count[l[i]] == 0) continue;  // alone in its label: s = 0
    const double a = sum[l[i]] / double(count[l[i]]);
    double b = std::numeric_limits<double>::infinity();
    for (int64_t c = 0; c < 16; ++c)
      if (c != l[i] && count[c] > 0) b = std::min(b, sum[c] / double(count[c]));
    total += (b - a) / std::max(a, b);
  }
  return total / double(n);
}

// `n` points in 5-D around 4 cluster centres 1.5 apart (unit noise): clusters that overlap, so
// neither metric is at its bound.
struct Clustered {
  torch::Tensor x;
  std::vector<int64_t> labels;
};
Clustered clustered(int64_t n, uint64_t seed) {
  torch::manual_seed(seed);
  Clustered c;
  c.x = torch::randn({n, 5}, torch::kFloat64);
  for (int64_t i = 0; i < n; ++i) {
    c.labels.push_back(i % 4);
    c.x[i][i % 4] += 1.5;
  }
  return c;
}

}  // namespace

TEST_CASE("feature metrics: silhouette of two pairs on a line, and of a lone point, by hand") {
  // A = {0, 1}, B = {10, 11}: a = 1 for all; b = 10.5 for 0 and 11, 9.5 for 1 and 10.
  const double pairs = (9.5 / 10.5 + 8.5 / 9.5) / 2;
  CHECK(handscs::silhouette_score(points_1d({0, 1, 10, 11}), label_tensor({0, 0, 1, 1})) ==
        Approx(pairs).epsilon(1e-12));
  // A lone point (label 5, far away) scores 0 and leaves the others' b unchanged.
  CHECK(handscs::silhouette_score(points_1d({0, 1, 10, 11, 100}), label_tensor({0, 0, 1, 1, 5})) ==
        Approx(4 * pairs / 5).epsilon(1e-12));
  // Far from the origin the same (the distances are taken about the centroid).
  CHECK(handscs::silhouette_score(points_1d({1e6, 1e6 + 1, 1e6 + 10, 1e6 + 11}), label_tensor({0, 0, 1, 1})) ==
        Approx(pairs).epsilon(1e-9));
  CHECK(handscs_test::error_of([] { handscs::silhouette_score(points_1d({0, 1, 2}), label_tensor({3, 3, 3})); }) ==
        "silhouette: needs 2 to N - 1 distinct labels, got 1 for 3 points");
}

TEST_CASE("feature metrics: k-NN ties go to the nearer index, votes to the smaller label") {
  // Points 0, 1, 2, 3 with labels 0, 0, 1, 1, k = 1: point 1's neighbours 0 and 2 tie at distance 1
  // (index 0 wins: right), so do point 2's 1 and 3 (index 1 wins: wrong). 3 of 4.
  const auto first = handscs::knn_accuracy_loo(points_1d({0, 1, 2, 3}), label_tensor({0, 0, 1, 1}), 1);
  CHECK(first.accuracy == 0.75);
  CHECK(first.balanced == 0.75);  // label 0: 2 of 2, label 1: 1 of 2
  // k = 3: each point's neighbours are the three others. Labels 2, 1, 0, 3: every vote is a
  // three-way tie won by the smallest label among the others, never the point's own: 0 of 4.
  const auto x = points_1d({0, 1, 2, 3});
  CHECK(handscs::knn_accuracy_loo(x, label_tensor({2, 1, 0, 3}), 3).accuracy == 0.0);
  // Labels 0, 1, 0, 3: point 0 sees {1, 0, 3} (tie -> 0, right), point 1 {0, 0, 3} (0, wrong),
  // point 2 {0, 1, 3} (tie -> 0, right), point 3 {0, 1, 0} (0, wrong): 2 of 4. Balanced: label 0
  // 2 of 2, labels 1 and 3 none of 1: (1 + 0 + 0) / 3.
  const auto votes = handscs::knn_accuracy_loo(x, label_tensor({0, 1, 0, 3}), 3);
  CHECK(votes.accuracy == 0.5);
  CHECK(votes.balanced == Approx(1.0 / 3).epsilon(1e-15));
  // Transfer: the query points take their labels from the reference set, themselves not in it.
  CHECK(handscs::knn_accuracy_transfer(x, label_tensor({0, 0, 1, 1}), points_1d({0.2, 2.9}),
                                       label_tensor({0, 0}), 1).accuracy == 0.5);
  CHECK(handscs_test::error_of([&] { handscs::knn_accuracy_loo(x, label_tensor({0, 0, 1, 1}), 4); }) ==
        "k-NN: k = 4 needs at least that many neighbour candidates, there are 3");
}

TEST_CASE("feature metrics: agree with plain-loop references on clustered random data") {
  // 700 points: more than one block of 512 rows, so the blocks' seams are crossed.
  const Clustered a = clustered(700, 3);
  const Clustered b = clustered(150, 4);
  const auto la = label_tensor(a.labels), lb = label_tensor(b.labels);
  for (int64_t k : {1, 10}) {
    INFO("k = " << k);
    const auto knn = handscs::knn_accuracy_loo(a.x, la, k);
    const auto [accuracy, balanced] = reference_knn(a.x, a.labels, a.x, a.labels, k, true);
    CHECK(knn.accuracy == accuracy);
    CHECK(knn.balanced == Approx(balanced).epsilon(1e-15));
    CHECK(knn.accuracy > 0.4);  // well above the 0.25 of guessing: the data has structure to find
    const auto transfer = handscs::knn_accuracy_transfer(a.x, la, b.x, lb, k);
    const auto [transfer_accuracy, transfer_balanced] = reference_knn(a.x, a.labels, b.x, b.labels, k, false);
    CHECK(transfer.accuracy == transfer_accuracy);
    CHECK(transfer.balanced == Approx(transfer_balanced).epsilon(1e-15));
  }
  const double silhouette = handscs::silhouette_score(a.x, la);
  CHECK(silhouette == Approx(reference_silhouette(a.x, a.labels)).margin(1e-12));
  CHECK(silhouette > 0.0);
  CHECK(silhouette < 0.5);
  // Single precision input gives the same as its double values.
  CHECK(handscs::silhouette_score(a.x.to(torch::kFloat32), la) ==
        Approx(reference_silhouette(a.x.to(torch::kFloat32).to(torch::kFloat64), a.labels)).margin(1e-12));
}
