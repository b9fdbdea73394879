// Exact nearest neighbours in descriptor space for L_con's correspondences pi(i) = argmin_j
// |P_t^i - P_t-1^j|^2 at any Gaussian count: a k-d tree over the previous step's descriptors.
// Every node keeps the tight box of its points in every dimension; a node is entered only when
// the query's distance to its box is below the best distance found (exact: the box distance bounds
// the distance to each point inside from below), the nearer child first.
//
// The descriptors of one pose lie on a 3-D surface inside R^|P| (they are functions of a point of
// the hand), so the tree prunes as in low dimension although |P| is 20-50. Points are stored in
// their principal axes (a rotation: distances unchanged), so that the splits follow the few
// directions the surface spreads in. A starting guess per row (the same Gaussian's row of the
// previous step, when rows persist) gives a first bound and orders the queries by tree position,
// so that consecutive queries visit the same leaves.
//
// Why boxes: another pose's descriptors lie off this surface, typically 7-30 times the spacing of
// its points away (real_demo, 10k Gaussians, random training pose pairs). A bound built from the
// split planes alone (Arya and Mount's incremental distance) sees only the few directions the tree
// splits in, so it had to visit every cell within that distance; the box bound also counts the
// query's offset from the surface in the thin directions, and prunes those cells
// (docs/BENCHMARKS.md#correspondence-search).
#pragma once

#include <cstdint>
#include <utility>
#include <vector>

#include <torch/types.h>

namespace handscs {

class DescriptorTree {
 public:
  // reference [N', D] (any float dtype; searched in float32, as the descriptors are computed).
  explicit DescriptorTree(const torch::Tensor& reference);

  // argmin_j |query_i - reference_j|^2 for every row: [N] int64. guess [N] int64 (optional): a
  // reference row per query row whose distance starts the search; any valid row keeps it exact.
  // The search runs in float32 and keeps every row within its rounding of the best; of those the
  // nearest in double wins, ties to the lowest row (as correspond_exact: train/nearest_in_double.h).
  torch::Tensor nearest(const torch::Tensor& query,  // [N, D]
                        const torch::Tensor& guess = {}) const;

  int64_t size() const { return static_cast<int64_t>(order_.size()); }
  int64_t dim() const { return dim_; }

 private:
  struct Node {
    int32_t split_dim = -1;  // -1: leaf
    float split = 0;         // left holds coordinates <= split, right >= split
    int32_t left = -1, right = -1;
    int32_t begin = 0, end = 0;  // rows [begin, end) of points_ (tree order)
  };

  int32_t build(int32_t begin, int32_t end);
  torch::Tensor to_axes(const torch::Tensor& rows) const;  // [N, D] -> float32 [N, D]
  // Squared distance from `query` to the tight box of a node's points (0 inside it).
  float box_distance(const float* query, int32_t node) const;
  // One query's search: the best float32 distance, the bound within which a row may still be the
  // nearest (best + its rounding), and the rows found within it (tree order).
  struct Search {
    float best = 0, bound = 0;
    double query_norm = 0;  // |query| in the tree's centred coordinates
    std::vector<std::pair<float, int32_t>> within;
    void offer(float dist, int32_t slot, int64_t dim);
  };
  void search(const float* query, int32_t node, Search& state) const;

  int64_t dim_ = 0;
  torch::Tensor centre_;        // [D] float64: mean of the reference rows
  torch::Tensor axes_;          // [D, D] float64: principal axes (columns, largest spread first)
  std::vector<float> points_;   // [N', D] in tree order, centred and in principal axes
  std::vector<int64_t> order_;  // tree order -> reference row
  std::vector<int64_t> slot_;   // reference row -> tree order
  std::vector<Node> nodes_;
  std::vector<float> boxes_;    // per node: lowest then highest coordinate of its points [2 D]
  torch::Tensor reference_;     // [N', D]: the reference rows as given, float32 or float64 (the last step)
};

}  // namespace handscs
