#include "train/consistency.h"

#include <torch/types.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <type_traits>
#include <vector>

#include "core/error.h"
#include "hand/lbs.h"
#include "train/nearest_in_double.h"

namespace handscs {

namespace {
// Floor of s_i^2 (m^2) in the group normalisation: (0.1 mm)^2, far below any Gaussian the
// densification keeps, so it only guards against a degenerate covariance.
constexpr double kMinExtent2 = 1e-8;
// Rows per block of the exact search: 1024 x N' distances in flight (10k Gaussians: 40 MB).
constexpr int64_t kSearchBlock = 1024;
}  // namespace

torch::Tensor pose_feature(const torch::Tensor& pose) {
  const auto fingers = pose.reshape({-1}).slice(0, 3, 48).reshape({15, 3});
  const auto rot = rodrigues(fingers);
  return (rot - torch::eye(3, rot.options())).reshape({-1});
}

double pose_similarity(const torch::Tensor& feature_a, const torch::Tensor& feature_b, double delta) {
  const double sq = (feature_a - feature_b).pow(2).sum().item<double>();
  return std::exp(-sq / (2 * delta * delta));
}

torch::Tensor correspond_exact(const torch::Tensor& query, const torch::Tensor& reference) {
  torch::NoGradGuard no_grad;
  // Searched in double when given double (gradient checks), else in float32.
  const auto dtype = query.scalar_type() == torch::kFloat64 ? torch::kFloat64 : torch::kFloat32;
  const auto q = query.detach().to(dtype).contiguous();
  const auto r = reference.detach().to(dtype).contiguous();
  const int64_t d = q.size(1);
  auto out = torch::empty({q.size(0)}, torch::kInt64);
  if (q.size(0) == 0) return out;
  require(r.size(0) > 0, "correspond_exact: no reference rows to search");
  const auto r_sq = r.pow(2).sum(1);  // [N']
  const double r_norm = std::sqrt(r_sq.max().item<double>());
  const auto q_norm = q.pow(2).sum(1).sqrt().to(torch::kFloat64).contiguous();
  const bool float64 = dtype == torch::kFloat64;
  int64_t* op = out.data_ptr<int64_t>();
  for (int64_t start = 0; start < q.size(0); start += kSearchBlock) {
    const int64_t end = std::min(start + kSearchBlock, q.size(0));
    const auto block = q.slice(0, start, end);
    // |q - r|^2 = |q|^2 - 2 q.r + |r|^2; |q|^2 is constant per row and does not change the argmin.
    const auto dist = r_sq.unsqueeze(0) - 2 * block.matmul(r.t());
    // Every row within the GEMM's rounding of the row's least value may be the nearest (a double
    // GEMM's rounding is far below any distance the training tells apart: ties only).
    auto tolerance = torch::zeros({end - start, 1}, dist.options());
    if (!float64) {
      const double* norms = q_norm.data_ptr<double>();
      float* tol = tolerance.data_ptr<float>();
      for (int64_t i = start; i < end; ++i)
        tol[i - start] = gemm_search_tolerance(d, norms[i], r_norm);
    }
    // A row with no number in it keeps the GEMM's own argmin (the training checks skip its step).
    const auto [least, argmin] = dist.min(1, true);
    out.slice(0, start, end).copy_(argmin.squeeze(1));
    // [M, 2]: (row of the block, reference row), by row.
    const auto within = dist.le(least + tolerance).nonzero().contiguous();
    const int64_t* pairs = within.data_ptr<int64_t>();
    std::vector<int64_t> rows;
    for (int64_t m = 0; m < within.size(0);) {
      const int64_t row = pairs[2 * m];
      rows.clear();
      for (; m < within.size(0) && pairs[2 * m] == row; ++m) rows.push_back(pairs[2 * m + 1]);
      // The last step in double (train/nearest_in_double.h).
      op[start + row] = nearest_in_double(q, start + row, r, rows);
    }
  }
  return out;
}

namespace {

// argmin over each row's candidates by direct loops: no [N, K, D] temporaries (at N = 10k, K = 32,
// |P| = 36 those were 46 MB each and most of the search's time). The float distances find the
// candidates within their rounding of the least; the distance in double picks among them.
template <class T>
void candidate_argmin(const T* query, const T* reference, const int64_t* candidates, int64_t n,
                      int64_t k, int64_t d, int64_t* out) {
#pragma omp parallel
  {
    std::vector<T> dist(k);
    std::vector<int64_t> within;
#pragma omp for schedule(static)
    for (int64_t i = 0; i < n; ++i) {
      const T* q = query + i * d;
      const int64_t* row_candidates = candidates + i * k;
      T best = std::numeric_limits<T>::infinity();
      for (int64_t c = 0; c < k; ++c) {
        const T* r = reference + row_candidates[c] * d;
        T sum = 0;
        for (int64_t e = 0; e < d; ++e) sum += (q[e] - r[e]) * (q[e] - r[e]);
        dist[c] = sum;
        best = std::min(best, sum);
      }
      // A double search rounds far below any distance the training tells apart: ties only.
      const double bound =
          static_cast<double>(best) +
          (std::is_same_v<T, float> ? direct_search_tolerance(d, best, 0.0) : 0.0);
      within.clear();
      for (int64_t c = 0; c < k; ++c)
        if (dist[c] <= bound) within.push_back(row_candidates[c]);
      out[i] = within.empty() ? row_candidates[0]  // no number: the training checks skip the step
                              : nearest_in_double(q, reference, d, within.data(),
                                                  static_cast<int64_t>(within.size()));
    }
  }
}

}  // namespace

torch::Tensor correspond_candidates(const torch::Tensor& query, const torch::Tensor& reference,
                                    const torch::Tensor& candidates) {
  // Searched in double when given double (gradient checks), else in float32.
  const auto dtype = query.scalar_type() == torch::kFloat64 ? torch::kFloat64 : torch::kFloat32;
  const auto q = query.detach().to(dtype).contiguous();
  const auto r = reference.detach().to(dtype).contiguous();
  const auto c = candidates.to(torch::kInt64).contiguous();
  const int64_t n = q.size(0), k = c.size(1), d = q.size(1);
  auto out = torch::empty({n}, torch::kInt64);
  if (n == 0) return out;
  require(k > 0, "correspond_candidates: every row needs at least one candidate");
  if (dtype == torch::kFloat64)
    candidate_argmin(q.data_ptr<double>(), r.data_ptr<double>(), c.data_ptr<int64_t>(), n, k, d,
                     out.data_ptr<int64_t>());
  else
    candidate_argmin(q.data_ptr<float>(), r.data_ptr<float>(), c.data_ptr<int64_t>(), n, k, d,
                     out.data_ptr<int64_t>());
  return out;
}

torch::Tensor nearest_neighbours(const torch::Tensor& points, int64_t k) {
  torch::NoGradGuard no_grad;
  const auto p = points.detach();
  const int64_t n = p.size(0);
  const int64_t kk = std::min(k, n);
  const auto p_sq = p.pow(2).sum(1);
  std::vector<torch::Tensor> parts;
  for (int64_t start = 0; start < n; start += kSearchBlock) {
    const auto block = p.slice(0, start, std::min(start + kSearchBlock, n));
    auto dist = p_sq.unsqueeze(0) - 2 * block.matmul(p.t()) + block.pow(2).sum(1, true);
    // Each point is its own nearest neighbour, whatever rounding says.
    const auto rows = torch::arange(block.size(0), torch::kInt64);
    dist.index_put_({rows, rows + start}, -1.0);
    parts.push_back(std::get<1>(dist.topk(kk, 1, /*largest=*/false, /*sorted=*/true)));
  }
  if (parts.empty()) return torch::zeros({0, kk}, torch::kInt64);
  return torch::cat(parts);
}

torch::Tensor consistency_attributes(const torch::Tensor& means, const torch::Tensor& covariances,
                                     const torch::Tensor& colors, const torch::Tensor& embed_geometry,
                                     const torch::Tensor& embed_appearance) {
  return torch::cat({means, covariances.reshape({means.size(0), 9}), colors, embed_geometry,
                     embed_appearance},
                    1);
}

torch::Tensor consistency_distances(const torch::Tensor& attributes, const torch::Tensor& matched,
                                    const torch::Tensor& covariances,
                                    ConsistencyConfig::Normalize normalize) {
  TORCH_CHECK(attributes.sizes() == matched.sizes() && attributes.dim() == 2 && attributes.size(1) >= 15,
              "consistency_distances: attributes and matched must be equal [N, 15 + 2d], got ",
              attributes.sizes(), " and ", matched.sizes());
  const auto squared = (attributes - matched).pow(2);
  if (normalize == ConsistencyConfig::Normalize::none) return squared.sum(1);
  // s_i^2 = tr(Sigma'_i) / 3: the Gaussian's mean squared extent, a constant of the loss.
  const auto extent2 = covariances.detach().diagonal(0, 1, 2).sum(1).div(3).clamp_min(kMinExtent2);
  const auto group = [&](int64_t first, int64_t count) { return squared.narrow(1, first, count).mean(1); };
  auto total = group(0, 3) / extent2 + group(3, 9) / extent2.pow(2) + group(12, 3);
  if (attributes.size(1) > 15) total = total + group(15, attributes.size(1) - 15);
  return total;
}

torch::Tensor pairs_decoded_at_both_steps(const torch::Tensor& decoded_now,
                                          const torch::Tensor& decoded_prev, const torch::Tensor& match) {
  auto both = decoded_now.defined() ? decoded_now : torch::ones({match.size(0)}, torch::kBool);
  if (decoded_prev.defined()) both = both.logical_and(decoded_prev.index_select(0, match));
  return both.nonzero().squeeze(1);
}

}  // namespace handscs
