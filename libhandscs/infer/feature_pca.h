// Colours from features (paper Fig. 1(b)): standardise each column, project onto the first three
// principal components, and map each component to [0, 1] between two percentiles. Each step is
// fitted once (on the poses pooled) and applied to every pose, so a feature value has one colour
// in every pose and colours can be compared across poses.
#pragma once

#include <torch/types.h>

namespace handscs {

// z = (x - mean) / scale per column; scale is the population standard deviation (ddof 0), or 1
// for a column that is constant (it stays 0 after centring instead of dividing by ~0).
struct Standardizer {
  torch::Tensor mean;   // [D] float64
  torch::Tensor scale;  // [D] float64
  torch::Tensor apply(const torch::Tensor& x) const;  // [N, D] -> [N, D] float64
};
Standardizer fit_standardizer(const torch::Tensor& x);  // [N, D]

// The leading principal axes of (centred) data: the eigenvectors of its covariance with the
// largest eigenvalues, each signed so that its largest-magnitude loading is positive.
struct PcaBasis {
  torch::Tensor mean;        // [D] float64
  torch::Tensor components;  // [K, D] float64, orthonormal rows
  torch::Tensor explained;   // [K] share of the total variance along each axis
  torch::Tensor project(const torch::Tensor& x) const;  // [N, D] -> [N, K]
};
// x [N, D]; K = min(count, D) axes (missing ones, when D < count, are left out).
PcaBasis fit_pca(const torch::Tensor& x, int64_t count);

// Per column: lo/hi = the `percentile` and 100 - `percentile` percentiles (linear interpolation,
// as numpy's default); apply() maps lo -> 0, hi -> 1 and clamps. A column with hi == lo maps to 0.5.
struct ColourRange {
  torch::Tensor lo, hi;  // [K] float64
  torch::Tensor apply(const torch::Tensor& x) const;  // [N, K] -> [N, K] in [0, 1]
};
ColourRange fit_colour_range(const torch::Tensor& x, double percentile);  // x [N, K]

// The three together, fitted on pooled rows: features [N, D] -> RGB [N, 3] in [0, 1].
struct FeatureColouring {
  Standardizer standardizer;
  PcaBasis pca;
  ColourRange range;
  torch::Tensor colours(const torch::Tensor& features) const;  // [N, D] -> [N, 3]
};
FeatureColouring fit_feature_colouring(const torch::Tensor& pooled, double percentile);

}  // namespace handscs
