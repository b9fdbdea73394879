// Inter-pose consistency (paper §3.2): pose similarity w = exp(-|Phi(theta_t) - Phi(theta_t-1)|^2 /
// (2 delta^2)) with Phi = the 135-D MANO pose feature, correspondences pi(i) = argmin_j |P_t^i -
// P_t-1^j|^2, and L_con = w * reduce_i |M_t^i - M_t-1^pi(i)|^2 with M = (x', Sigma', c', e_g, e_a).
#pragma once

#include <torch/types.h>

namespace handscs {

// pose [48] axis-angle (absolute finger rotations) -> [135] = (R_j - I) flattened, 15 finger joints.
torch::Tensor pose_feature(const torch::Tensor& pose);

// exp(-|a - b|^2 / (2 delta^2)) of two pose features.
double pose_similarity(const torch::Tensor& feature_a, const torch::Tensor& feature_b, double delta);

// Exact argmin_j |query_i - reference_j|^2 for every row i: query [N, D], reference [N', D] -> [N]
// int64. Blocked so memory stays O(block x N').
torch::Tensor correspond_exact(const torch::Tensor& query, const torch::Tensor& reference);

// argmin over the candidate set only: candidates [N, K] int64 indices into reference.
torch::Tensor correspond_candidates(const torch::Tensor& query, const torch::Tensor& reference,
                                    const torch::Tensor& candidates);

// The K nearest rows of points [N, 3] to each row (itself included first): [N, min(K, N)] int64.
torch::Tensor nearest_neighbours(const torch::Tensor& points, int64_t k);

// Attributes M of every Gaussian as one [N, 3 + 9 + 3 + 2d] matrix: x', vec(Sigma'), c', e_g, e_a.
torch::Tensor consistency_attributes(const torch::Tensor& means, const torch::Tensor& covariances,
                                     const torch::Tensor& colors, const torch::Tensor& embed_geometry,
                                     const torch::Tensor& embed_appearance);

}  // namespace handscs
