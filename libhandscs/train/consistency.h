// Inter-pose consistency (paper §3.2): pose similarity w = exp(-|Phi(theta_t) - Phi(theta_t-1)|^2 /
// (2 delta^2)) with Phi = the 135-D MANO pose feature, correspondences pi(i) = argmin_j |P_t^i -
// P_t-1^j|^2, and L_con = w * reduce_i |M_t^i - M_t-1^pi(i)|^2 with M = (x', Sigma', c', e_g, e_a).
#pragma once

#include <string>

#include <torch/types.h>

#include "run/train_config.h"

namespace handscs {

// pose [48] axis-angle (absolute finger rotations) -> [135] = (R_j - I) flattened, 15 finger joints.
torch::Tensor pose_feature(const torch::Tensor& pose);

// exp(-|a - b|^2 / (2 delta^2)) of two pose features.
double pose_similarity(const torch::Tensor& feature_a, const torch::Tensor& feature_b, double delta);

// Exact argmin_j |query_i - reference_j|^2 for every row i: query [N, D], reference [N', D] -> [N]
// int64, by the distance in double, ties to the lowest j (the same answer as the k-d tree's:
// train/nearest_in_double.h). A float GEMM finds the rows within its rounding of the least; blocked
// so memory stays O(block x N').
torch::Tensor correspond_exact(const torch::Tensor& query, const torch::Tensor& reference);

// argmin over the candidate set only: candidates [N, K] int64 indices into reference (in double,
// ties to the lowest index).
torch::Tensor correspond_candidates(const torch::Tensor& query, const torch::Tensor& reference,
                                    const torch::Tensor& candidates);

// The K nearest rows of points [N, 3] to each row (itself included first): [N, min(K, N)] int64.
torch::Tensor nearest_neighbours(const torch::Tensor& points, int64_t k);

// Attributes M of every Gaussian as one [N, 3 + 9 + 3 + 2d] matrix: x', vec(Sigma'), c', e_g, e_a.
torch::Tensor consistency_attributes(const torch::Tensor& means, const torch::Tensor& covariances,
                                     const torch::Tensor& colors, const torch::Tensor& embed_geometry,
                                     const torch::Tensor& embed_appearance);

// Per-Gaussian distance [N] between attributes [N, 15 + 2d] and the previous step's rows matched
// to them [N, 15 + 2d]. normalize "none": |M_i - M'_pi(i)|^2 over all columns (the paper's term).
// "groups": every attribute group is made scale-free and averaged over its columns, and the groups
// are summed, so each can hold the avatar together: |dx'|^2/(3 s^2) + |dSigma'|_F^2/(9 s^4) +
// |dc'|^2/3 + |de|^2/(2d), with s_i^2 = tr(Sigma'_i)/3 of the current Gaussian (no gradient).
torch::Tensor consistency_distances(const torch::Tensor& attributes, const torch::Tensor& matched,
                                    const torch::Tensor& covariances,  // [N, 3, 3] Sigma'
                                    ConsistencyConfig::Normalize normalize);

// train.cull: the rows i [K] int64 (increasing) whose Gaussian was decoded at this step and whose
// match match[i] at the previous one; decoded_now [N], decoded_prev [N'] bool, either undefined when
// every Gaussian was decoded; match [N] int64 into the previous step's rows.
torch::Tensor pairs_decoded_at_both_steps(const torch::Tensor& decoded_now,
                                          const torch::Tensor& decoded_prev, const torch::Tensor& match);

}  // namespace handscs
