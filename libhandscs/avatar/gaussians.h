// Per-Gaussian state of the avatar in canonical space: learnable attributes and embeddings, plus the
// skinning data copied from the nearest rig vertex. Rows can be selected/appended (densification).
#pragma once

#include <string>
#include <vector>

#include <torch/types.h>

#include "avatar/avatar_config.h"
#include "hand/rig.h"

namespace handscs {

struct GaussianState {
  // Learnable (requires_grad):
  torch::Tensor means;             // [N, 3] canonical centres x (m)
  torch::Tensor log_scales;        // [N, 3] log of the axis standard deviations (m)
  torch::Tensor rotations;         // [N, 4] quaternions (w, x, y, z), normalised when used
  torch::Tensor colors;            // [N, 3] RGB (clamped to [0, 1] when composited)
  torch::Tensor opacity_logits;    // [N] logit of the opacity
  torch::Tensor embed_geometry;    // [N, d] e_g (d = 0 when embeddings are off)
  torch::Tensor embed_appearance;  // [N, d] e_a
  // Fixed:
  torch::Tensor skin_weights;  // [N, 16] LBS weights of the nearest rig vertex
  torch::Tensor vertex_ids;    // [N] int64 nearest rig vertex (for its blend offsets)

  int64_t size() const { return means.size(0); }

  // Named learnable tensors, in a fixed order (optimiser groups and checkpoints use the names).
  std::vector<std::pair<std::string, torch::Tensor*>> learnable();
  // Every per-Gaussian tensor (learnable and fixed), in a fixed order.
  std::vector<std::pair<std::string, torch::Tensor*>> all();

  // Rows `index` ([K] int64) of every tensor, as new leaf tensors.
  GaussianState select(const torch::Tensor& index) const;
  // Appends `other`'s rows to every tensor (new leaf tensors).
  void append(const GaussianState& other);
};

// One Gaussian per rig vertex: centres at the template, isotropic scales from the mean distance to
// the 3 nearest vertices, identity rotations, random colour and opacity, N(0, std) embeddings.
GaussianState init_gaussians_from_rig(const Rig& rig, const AvatarConfig& config);

}  // namespace handscs
