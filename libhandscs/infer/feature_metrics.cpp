#include "infer/feature_metrics.h"

#include <algorithm>
#include <limits>
#include <string>
#include <vector>

#include "core/error.h"

namespace handscs {

namespace {

// Rows per block of the distance matrix: 512 x N doubles is 40 MB at N = 10k (densification's cap).
constexpr int64_t kBlockRows = 512;

void check_points(const torch::Tensor& x, const torch::Tensor& labels, const char* who) {
  TORCH_CHECK(x.dim() == 2 && x.size(0) > 0, who, ": points must be a non-empty [N, D] tensor, got ", x.sizes());
  TORCH_CHECK(labels.dim() == 1 && labels.size(0) == x.size(0), who, ": labels must be [", x.size(0),
              "], got ", labels.sizes());
  TORCH_CHECK(labels.scalar_type() == torch::kLong, who, ": labels must be int64");
  TORCH_CHECK(labels.min().item<int64_t>() >= 0, who, ": labels must be >= 0");
}

std::vector<int64_t> label_vector(const torch::Tensor& labels) {
  const auto l = labels.contiguous();
  return {l.data_ptr<int64_t>(), l.data_ptr<int64_t>() + l.numel()};
}

// Squared distances [rows, M] from x[begin, end) to every row of y (both already centred on one
// point, which keeps |a|^2 + |b|^2 - 2 a.b from cancelling when points lie far from the origin).
torch::Tensor squared_distances(const torch::Tensor& x, int64_t begin, int64_t end, const torch::Tensor& y,
                                const torch::Tensor& y_norms) {
  const auto a = x.slice(0, begin, end);
  return (a.pow(2).sum(1, true) + y_norms.unsqueeze(0) - 2 * a.matmul(y.t())).clamp_min(0);
}

// The label k-NN predicts from the k nearest (squared distance, index) pairs.
int64_t vote(const std::vector<std::pair<double, int64_t>>& nearest, const std::vector<int64_t>& labels,
             std::vector<int64_t>& counts) {
  std::fill(counts.begin(), counts.end(), 0);
  for (const auto& [d, j] : nearest) ++counts[labels[j]];
  return std::max_element(counts.begin(), counts.end()) - counts.begin();  // first max: smallest label
}

KnnScore knn_accuracy(const torch::Tensor& reference_in, const torch::Tensor& reference_labels,
                    const torch::Tensor& query_in, const torch::Tensor& query_labels, int64_t k,
                    bool leave_one_out) {
  const int64_t m = reference_in.size(0), n = query_in.size(0);
  TORCH_CHECK(reference_in.size(1) == query_in.size(1), "k-NN: reference has ", reference_in.size(1),
              " columns, query ", query_in.size(1));
  const int64_t candidates = leave_one_out ? m - 1 : m;
  require(k >= 1 && k <= candidates, "k-NN: k = " + std::to_string(k) + " needs at least that many "
          "neighbour candidates, there are " + std::to_string(candidates));
  const auto centre = reference_in.to(torch::kFloat64).mean(0);
  const auto reference = (reference_in.to(torch::kFloat64) - centre).contiguous();
  const auto query = (query_in.to(torch::kFloat64) - centre).contiguous();
  const auto reference_norms = reference.pow(2).sum(1);
  const auto ref_labels = label_vector(reference_labels);
  const auto q_labels = label_vector(query_labels);
  const int64_t num_labels = 1 + std::max(*std::max_element(ref_labels.begin(), ref_labels.end()),
                                          *std::max_element(q_labels.begin(), q_labels.end()));
  std::vector<int64_t> counts(num_labels), per_label(num_labels, 0), right_per_label(num_labels, 0);
  std::vector<std::pair<double, int64_t>> row;
  int64_t right = 0;
  for (int64_t begin = 0; begin < n; begin += kBlockRows) {
    const int64_t end = std::min(n, begin + kBlockRows);
    const auto d2 = squared_distances(query, begin, end, reference, reference_norms).contiguous();
    const double* d = d2.data_ptr<double>();
    for (int64_t i = begin; i < end; ++i, d += m) {
      row.clear();
      for (int64_t j = 0; j < m; ++j)
        if (!(leave_one_out && j == i)) row.emplace_back(d[j], j);
      std::partial_sort(row.begin(), row.begin() + k, row.end());  // by distance, then index
      row.resize(k);
      const bool hit = vote(row, ref_labels, counts) == q_labels[i];
      right += hit;
      ++per_label[q_labels[i]];
      right_per_label[q_labels[i]] += hit;
    }
  }
  KnnScore score;
  score.accuracy = double(right) / double(n);
  int64_t present = 0;
  for (int64_t c = 0; c < num_labels; ++c)
    if (per_label[c] > 0) {
      score.balanced += double(right_per_label[c]) / double(per_label[c]);
      ++present;
    }
  score.balanced /= double(present);
  return score;
}

}  // namespace

KnnScore knn_accuracy_loo(const torch::Tensor& x, const torch::Tensor& labels, int64_t k) {
  check_points(x, labels, "knn_accuracy_loo");
  return knn_accuracy(x, labels, x, labels, k, true);
}

KnnScore knn_accuracy_transfer(const torch::Tensor& reference, const torch::Tensor& reference_labels,
                               const torch::Tensor& query, const torch::Tensor& query_labels, int64_t k) {
  check_points(reference, reference_labels, "knn_accuracy_transfer (reference)");
  check_points(query, query_labels, "knn_accuracy_transfer (query)");
  return knn_accuracy(reference, reference_labels, query, query_labels, k, false);
}

double silhouette_score(const torch::Tensor& x_in, const torch::Tensor& labels) {
  check_points(x_in, labels, "silhouette_score");
  const int64_t n = x_in.size(0);
  const auto l = label_vector(labels);
  const int64_t num_labels = 1 + *std::max_element(l.begin(), l.end());
  std::vector<int64_t> sizes(num_labels, 0);
  for (int64_t v : l) ++sizes[v];
  const int64_t distinct = std::count_if(sizes.begin(), sizes.end(), [](int64_t s) { return s > 0; });
  require(distinct >= 2 && distinct <= n - 1,
          "silhouette: needs 2 to N - 1 distinct labels, got " + std::to_string(distinct) + " for " +
              std::to_string(n) + " points");
  const auto x = (x_in.to(torch::kFloat64) - x_in.to(torch::kFloat64).mean(0)).contiguous();
  const auto norms = x.pow(2).sum(1);
  // Sum of distances from each point to each label's points: distances [B, N] x one-hot [N, L].
  const auto one_hot = torch::zeros({n, num_labels}, torch::kFloat64)
                           .scatter_(1, labels.to(torch::kLong).unsqueeze(1), 1.0);
  double total = 0;
  for (int64_t begin = 0; begin < n; begin += kBlockRows) {
    const int64_t end = std::min(n, begin + kBlockRows);
    auto distances = squared_distances(x, begin, end, x, norms).sqrt().contiguous();
    // A point's distance to itself is 0, not the expansion's rounding residue.
    for (int64_t i = begin; i < end; ++i) distances.data_ptr<double>()[(i - begin) * n + i] = 0;
    const auto sums = distances.matmul(one_hot).contiguous();
    const double* s = sums.data_ptr<double>();
    for (int64_t i = begin; i < end; ++i, s += num_labels) {
      const int64_t own = l[i];
      if (sizes[own] == 1) continue;  // s_i = 0
      const double a = s[own] / double(sizes[own] - 1);
      double b = std::numeric_limits<double>::infinity();
      for (int64_t c = 0; c < num_labels; ++c)
        if (c != own && sizes[c] > 0) b = std::min(b, s[c] / double(sizes[c]));
      const double denominator = std::max(a, b);
      total += denominator > 0 ? (b - a) / denominator : 0.0;
    }
  }
  return total / double(n);
}

}  // namespace handscs
