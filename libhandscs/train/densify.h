// 3DGS-style adaptive density control for the avatar's canonical Gaussians: Gaussians whose mean
// view-space gradient exceeds a threshold are cloned (small) or split in two (large, scales / 1.6),
// transparent ones are pruned, and the count never exceeds a cap. Every per-Gaussian tensor
// (embeddings, skinning weights, optimiser moments) follows.
#pragma once

#include <cstdint>

#include <torch/types.h>

#include "avatar/gaussians.h"
#include "run/checkpoint.h"
#include "train/adam.h"
#include "run/train_config.h"

namespace handscs {

class Densifier {
 public:
  explicit Densifier(const DensifyConfig& config) : config_(config) {}

  // One view's statistics after its backward: |dL/d mean2d| of the Gaussians it sees and which
  // ones it sees (both [N] float). The views of a step, on every rank, are summed and then added.
  struct ViewStatistics {
    torch::Tensor grad_norm;  // |dL/d mean2d| where visible, else 0
    torch::Tensor visible;    // 1 where the Gaussian's radius is positive, else 0
  };
  static ViewStatistics view_statistics(const torch::Tensor& means2d_grad,  // [N, 2]
                                        const torch::Tensor& radii);        // [N] int32, 0 = culled
  void add(const ViewStatistics& statistics);
  // Clones/splits/prunes; returns the number of Gaussians after the change.
  int64_t densify_and_prune(GaussianState& gaussians, Adam& optimizer, uint64_t seed);

  bool due(int64_t iteration) const {
    return config_.enabled && iteration >= config_.start && iteration <= config_.stop &&
           iteration % config_.interval == 0;
  }
  // Checkpoint: the statistics gathered since the last densification ("densify/grad_sum" and
  // "densify/count", [N] float). load() of a checkpoint without them starts them at zero.
  void save(Checkpoint& checkpoint) const;
  void load(const Checkpoint& checkpoint);

 private:
  void reset(int64_t n);
  DensifyConfig config_;
  torch::Tensor grad_sum_;
  torch::Tensor count_;
};

}  // namespace handscs
