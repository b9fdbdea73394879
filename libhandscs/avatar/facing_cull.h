// Back-facing Gaussians (beyond the paper; train.cull): the Gaussians whose rig vertex
// faces away from every camera of a step lie on the far side of the hand's closed surface, behind
// its front side, so they are neither decoded nor rasterised. Each Gaussian's normal is its rig
// vertex's rest normal (area-weighted face normals of the template) carried by the Gaussian's own
// blend transform T; a Gaussian is kept when n.(x - c) / (|n| |x - c|) <= max_cos for at least one
// camera centre c (x its LBS-posed centre, offsets not applied). max_cos > 0 keeps a band of
// Gaussians just past the silhouette: the normal is the rig's, not the Gaussian's, and the decoded
// offsets move Gaussians after the test. Off by default and not offered at inference: the skipped
// Gaussians do reach the exact image (docs/BENCHMARKS.md#model-forward-and-backward).
#pragma once

#include <array>
#include <vector>

#include <torch/types.h>

#include "hand/rig.h"

namespace handscs {

struct FacingCull {
  std::vector<std::array<double, 3>> camera_centres;  // world, metres; at least one
  double max_cos = 0.3;  // kept while the cosine between normal and view ray is at most this
  // The kept count is rounded up to a multiple of this (at least one, at most N) with the culled
  // Gaussians nearest the threshold: oneDNN builds its bf16 GEMM kernels for each row count, and a
  // count that changed every step made training with the cull slower than without it (the
  // benchmark's training steps at 2,872 Gaussians: 1,021 oneDNN primitive cache misses against
  // 435, 31.8 against 27.6 ms a step). 128 keeps a run's distinct counts to a few tens, cached, at
  // <= 127 rows decoded beyond the test.
  int64_t row_multiple = 128;
};

// Unit outward normal of each template vertex [V, 3] float64: the sum of its faces' cross
// products (each twice the face's area), normalised, turned outward when the faces run clockwise
// seen from outside (a negative signed volume; the rig's convention is counter-clockwise).
// A vertex without faces gets 0, and a Gaussian with a zero normal is always kept.
torch::Tensor rest_vertex_normals(const Rig& rig);

// Rows [K] int64, increasing, of the Gaussians kept (then rounded up by row_multiple). linear
// [N, 3, 3] (the 3x3 of each Gaussian's blend transform T, any strides), rest_normals [N, 3] and
// means [N, 3] in float32 or float64, no gradient taken. A non-finite row is kept (the rasterizer
// culls it with its own rules).
torch::Tensor facing_rows(const torch::Tensor& linear, const torch::Tensor& rest_normals,
                          const torch::Tensor& means, const FacingCull& cull);

}  // namespace handscs
