#include "train/consistency.h"

#include <torch/torch.h>

#include "hand/lbs.h"

namespace handscs {

namespace {
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
  const auto q = query.detach();
  const auto r = reference.detach();
  const auto r_sq = r.pow(2).sum(1);  // [N']
  std::vector<torch::Tensor> parts;
  for (int64_t start = 0; start < q.size(0); start += kSearchBlock) {
    const auto block = q.slice(0, start, std::min(start + kSearchBlock, q.size(0)));
    // |q - r|^2 = |q|^2 - 2 q.r + |r|^2; |q|^2 is constant per row and does not change the argmin.
    const auto dist = r_sq.unsqueeze(0) - 2 * block.matmul(r.t());
    parts.push_back(dist.argmin(1));
  }
  if (parts.empty()) return torch::zeros({0}, torch::kInt64);
  return torch::cat(parts);
}

torch::Tensor correspond_candidates(const torch::Tensor& query, const torch::Tensor& reference,
                                    const torch::Tensor& candidates) {
  torch::NoGradGuard no_grad;
  const auto gathered = reference.detach().index_select(0, candidates.reshape({-1}))
                            .view({candidates.size(0), candidates.size(1), -1});  // [N, K, D]
  const auto dist = (gathered - query.detach().unsqueeze(1)).pow(2).sum(2);       // [N, K]
  const auto best = dist.argmin(1, /*keepdim=*/true);                             // [N, 1]
  return candidates.gather(1, best).squeeze(1);
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

}  // namespace handscs
