#include "train/descriptor_tree.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include <ATen/ATen.h>
#include <torch/linalg.h>

#include "core/error.h"
#include "train/nearest_in_double.h"

namespace handscs {

namespace {
// Points per leaf: a leaf is scanned whole (a few cache lines of descriptors) while deeper trees
// cost more bound updates; 8 is a common choice, not tuned here.
constexpr int32_t kLeafSize = 8;
}  // namespace

DescriptorTree::DescriptorTree(const torch::Tensor& reference) {
  require(reference.dim() == 2, "descriptor tree: reference must be [N, D]");
  require(reference.size(0) < std::numeric_limits<int32_t>::max(), "descriptor tree: too many rows");
  dim_ = reference.size(1);
  const int64_t n = reference.size(0);
  const auto reference64 = reference.detach().to(torch::kFloat64);
  centre_ = n > 0 ? reference64.mean(0) : torch::zeros({dim_}, torch::kFloat64);
  const auto centred = reference64 - centre_;
  // Eigenvectors of the scatter matrix, in ascending order of eigenvalue: reversed.
  axes_ = dim_ == 0 ? torch::zeros({0, 0}, torch::kFloat64)
                    : std::get<1>(torch::linalg::eigh(centred.t().matmul(centred), "L")).flip(1).contiguous();
  reference_ = reference.detach()
                   .to(reference.scalar_type() == torch::kFloat64 ? torch::kFloat64 : torch::kFloat32)
                   .contiguous();
  const auto data = to_axes(reference);
  points_.assign(data.data_ptr<float>(), data.data_ptr<float>() + n * dim_);
  order_.resize(n);
  std::iota(order_.begin(), order_.end(), 0);
  if (n > 0) build(0, static_cast<int32_t>(n));
  // Points in tree order, so that a leaf's rows are contiguous.
  std::vector<float> sorted(points_.size());
  slot_.resize(n);
  for (int64_t k = 0; k < n; ++k) {
    std::copy_n(points_.begin() + order_[k] * dim_, dim_, sorted.begin() + k * dim_);
    slot_[order_[k]] = k;
  }
  points_.swap(sorted);
}

torch::Tensor DescriptorTree::to_axes(const torch::Tensor& rows) const {
  return (rows.detach().to(torch::kFloat64) - centre_).matmul(axes_).to(torch::kFloat32).contiguous();
}

int32_t DescriptorTree::build(int32_t begin, int32_t end) {
  const int32_t id = static_cast<int32_t>(nodes_.size());
  nodes_.push_back(Node{});
  nodes_[id].begin = begin;
  nodes_[id].end = end;
  // The tight box of the node's points (every dimension): its distance to a query bounds the
  // distance to every point inside from below.
  boxes_.resize(boxes_.size() + 2 * dim_);
  float* lo = boxes_.data() + static_cast<int64_t>(id) * 2 * dim_;
  float* hi = lo + dim_;
  std::fill_n(lo, dim_, std::numeric_limits<float>::infinity());
  std::fill_n(hi, dim_, -std::numeric_limits<float>::infinity());
  for (int32_t k = begin; k < end; ++k) {
    const float* p = points_.data() + order_[k] * dim_;
    for (int64_t d = 0; d < dim_; ++d) {
      lo[d] = std::min(lo[d], p[d]);
      hi[d] = std::max(hi[d], p[d]);
    }
  }
  if (end - begin <= kLeafSize) return id;
  // Split the dimension of widest spread at its median.
  int32_t best_dim = 0;
  float best_spread = -1;
  for (int64_t d = 0; d < dim_; ++d)
    if (hi[d] - lo[d] > best_spread) best_spread = hi[d] - lo[d], best_dim = static_cast<int32_t>(d);
  if (best_spread <= 0) return id;  // all points equal: one leaf
  const int32_t mid = begin + (end - begin) / 2;
  const auto coordinate = [&](int64_t row) { return points_[row * dim_ + best_dim]; };
  std::nth_element(order_.begin() + begin, order_.begin() + mid, order_.begin() + end,
                   [&](int64_t a, int64_t b) { return coordinate(a) < coordinate(b); });
  const float split = coordinate(order_[mid]);
  const int32_t left = build(begin, mid);
  const int32_t right = build(mid, end);
  nodes_[id].split_dim = best_dim;
  nodes_[id].split = split;
  nodes_[id].left = left;
  nodes_[id].right = right;
  return id;
}

float DescriptorTree::box_distance(const float* query, int32_t node_id) const {
  const float* lo = boxes_.data() + static_cast<int64_t>(node_id) * 2 * dim_;
  const float* hi = lo + dim_;
  float dist = 0;
#pragma omp simd reduction(+ : dist)
  for (int64_t d = 0; d < dim_; ++d) {
    const float gap = std::max(lo[d] - query[d], 0.f) + std::max(query[d] - hi[d], 0.f);
    dist += gap * gap;
  }
  return dist;
}

void DescriptorTree::search(const float* query, int32_t node_id, Search& state) const {
  const Node& node = nodes_[node_id];
  if (node.split_dim < 0) {
    for (int32_t k = node.begin; k < node.end; ++k) {
      const float* p = points_.data() + static_cast<int64_t>(k) * dim_;
      float dist = 0;
#pragma omp simd reduction(+ : dist)
      for (int64_t d = 0; d < dim_; ++d) dist += (query[d] - p[d]) * (query[d] - p[d]);
      state.offer(dist, k, dim_);
    }
    return;
  }
  // The nearer box first; the other only if it can still hold a point within the bound.
  const float left = box_distance(query, node.left);
  const float right = box_distance(query, node.right);
  const bool left_first = left <= right;
  const int32_t first = left_first ? node.left : node.right;
  const int32_t second = left_first ? node.right : node.left;
  if ((left_first ? left : right) <= state.bound) search(query, first, state);
  if ((left_first ? right : left) <= state.bound) search(query, second, state);
}

void DescriptorTree::Search::offer(float dist, int32_t slot, int64_t dim) {
  if (dist > bound) return;
  within.emplace_back(dist, slot);
  if (dist < best) {
    best = dist;
    bound = best + direct_search_tolerance(dim, best, query_norm);
  }
}

torch::Tensor DescriptorTree::nearest(const torch::Tensor& query, const torch::Tensor& guess) const {
  require(query.dim() == 2 && query.size(1) == dim_,
          "descriptor tree: query must be [N, " + std::to_string(dim_) + "]");
  const int64_t n = query.size(0);
  auto out = torch::empty({n}, torch::kInt64);
  if (n == 0) return out;
  require(size() > 0, "descriptor tree: no reference rows to search");
  const auto q = to_axes(query);
  torch::Tensor g;
  if (guess.defined()) {
    require(guess.numel() == n, "descriptor tree: guess must have one row per query row");
    g = guess.to(torch::kInt64).contiguous();
    require(g.min().item<int64_t>() >= 0 && g.max().item<int64_t>() < size(),
            "descriptor tree: guess rows out of range");
  }
  const float* qp = q.data_ptr<float>();
  const int64_t* gp = g.defined() ? g.data_ptr<int64_t>() : nullptr;
  // The last step compares the rows as given, in double (train/nearest_in_double.h).
  const auto original = query.detach().to(reference_.scalar_type()).contiguous();
  int64_t* op = out.data_ptr<int64_t>();
  // Queries in the tree order of their guesses: neighbouring queries share leaves (cache).
  std::vector<int64_t> queue(n);
  std::iota(queue.begin(), queue.end(), 0);
  if (gp)
    std::sort(queue.begin(), queue.end(),
              [&](int64_t a, int64_t b) { return slot_[gp[a]] < slot_[gp[b]]; });
#pragma omp parallel
  {
    Search state;
    std::vector<int64_t> rows;
#pragma omp for schedule(dynamic, 64)
    for (int64_t k = 0; k < n; ++k) {
      const int64_t i = queue[k];
      const float* row = qp + i * dim_;
      state.within.clear();
      state.best = state.bound = std::numeric_limits<float>::infinity();
      float norm2 = 0;
      for (int64_t d = 0; d < dim_; ++d) norm2 += row[d] * row[d];
      state.query_norm = std::sqrt(static_cast<double>(norm2));
      if (gp) {
        const int32_t slot = static_cast<int32_t>(slot_[gp[i]]);
        const float* p = points_.data() + static_cast<int64_t>(slot) * dim_;
        float dist = 0;
        for (int64_t d = 0; d < dim_; ++d) dist += (row[d] - p[d]) * (row[d] - p[d]);
        state.offer(dist, slot, dim_);
      }
      search(row, 0, state);
      rows.clear();
      for (const auto& [dist, slot] : state.within)
        if (dist <= state.bound) rows.push_back(order_[slot]);
      // No distance is a number: the first row (the training checks skip such a step).
      op[i] = rows.empty() ? order_[0] : nearest_in_double(original, i, reference_, rows);
    }
  }
  return out;
}

}  // namespace handscs
