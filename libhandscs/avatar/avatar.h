// The HandSCS avatar (paper §3.1): canonical Gaussians on the rig, SCS descriptor, offset decoders,
// posing by per-Gaussian blend transforms, and rendering with the splat rasterizer:
//   x' = x + dx + dx^f,  c' = c + dc + dc^f,  Sigma' = A Sigma A^T (A = dSigma^f dSigma),
//   posed mean = T (x' + blend offset),  posed covariance = A_T Sigma' A_T^T.
#pragma once

#include <optional>

#include <torch/types.h>

#include "avatar/avatar_config.h"
#include "avatar/decoders.h"
#include "avatar/facing_cull.h"
#include "avatar/frozen_decoders.h"
#include "avatar/gaussians.h"
#include "core/camera.h"
#include "hand/lbs.h"
#include "render/rasterize.h"
#include "scs/topology.h"
#include "scs/virtual_bones.h"

namespace handscs {

struct PosedGaussians {
  torch::Tensor means;        // [N, 3] world
  torch::Tensor covariances;  // [N, 6] world, upper triangle (xx, xy, xz, yy, yz, zz)
  torch::Tensor colors;       // [N, 3]
  torch::Tensor opacities;    // [N]
};

// Rasterises posed Gaussians from `camera` (render/rasterize.h); means2d_probe as there. One posed
// set may be rendered from several cameras (a pose decoded once).
RasterOutput render_posed(const PosedGaussians& posed, const Camera& camera,
                          const RasterSettings& settings, const torch::Tensor& means2d_probe = {});

// Several posed sets as one, rows in order (two hands rendered in one rasteriser call, so that each
// hides the other where it is in front). One set is returned as it is.
PosedGaussians join_posed(const std::vector<const PosedGaussians*>& sets);

// Everything one forward pass produces that losses and tools may need.
struct AvatarState {
  PosedGaussians posed;
  LbsOutput lbs;                  // of the rig for this pose (batch of 1)
  torch::Tensor lbs_means;        // [N, 3] LBS-posed canonical centres x'_lbs (no offsets)
  torch::Tensor descriptor;       // [N, |P|] structural coordinate P (undefined if not computed)
  DecodedOffsets offsets;
  torch::Tensor canonical_means;        // [N, 3] x'
  torch::Tensor canonical_covariances;  // [N, 3, 3] Sigma'
  torch::Tensor canonical_colors;       // [N, 3] c'
  VirtualBones virtual_bones;     // undefined tensors when M = 0 or SCS is off
  // With a FacingCull: the rows [K] int64 decoded and rendered; the others' decoder outputs are 0
  // and their opacities 0 (the rasterizer skips them). Undefined: every row (no cull, or none culled).
  torch::Tensor decoded_rows;

  // The share of the Gaussians decoded and rendered (1 without a cull).
  double decoded_fraction() const {
    return decoded_rows.defined() ? double(decoded_rows.numel()) / double(posed.means.size(0)) : 1.0;
  }
};

struct AvatarOutput {
  AvatarState state;
  RasterOutput render;
};

class Avatar {
 public:
  Avatar(const AvatarConfig& config, Rig rig);

  // pose [48], shape [10], trans [3] (any float dtype; computed in float32). Throws Error on
  // non-finite input. need_descriptor forces P even when the decoders do not use it (for L_con).
  // Without autograd (inference mode or no-grad) the decoders run in their frozen form
  // (avatar/frozen_decoders.h), rebuilt whenever a weight or an embedding has changed.
  // cull: decode and render only the Gaussians facing one of its cameras (avatar/facing_cull.h);
  // the descriptor is still computed for every Gaussian.
  AvatarState pose(const torch::Tensor& pose, const torch::Tensor& shape,
                   const torch::Tensor& trans, bool need_descriptor = false,
                   const FacingCull* cull = nullptr);

  AvatarOutput forward(const torch::Tensor& pose, const torch::Tensor& shape,
                       const torch::Tensor& trans, const Camera& camera,
                       const RasterSettings& settings, const torch::Tensor& means2d_probe = {},
                       bool need_descriptor = false);

  // Converts every Gaussian tensor and network to `dtype` (float32 by default; float64 for checks).
  void set_dtype(torch::ScalarType dtype);

  const AvatarConfig& config() const { return config_; }
  const Rig& rig() const { return rig_; }
  const BoneTopology& topology() const { return topology_; }
  GaussianState& gaussians() { return gaussians_; }
  OffsetDecoders& decoders() { return decoders_; }
  // From now on this avatar decodes with `other`'s decoders (the same module, so the same weights
  // and gradients); its own are dropped. For model.shared_decoders (train/trainer.h).
  void share_decoders(Avatar& other);
  VirtualBoneGenerator& generator() { return generator_; }  // null when M = 0 or SCS is off
  // Width of P as computed (static bones, then virtual bones); the decoders see it when SCS is on.
  int64_t descriptor_dim() const;

  // The SCS descriptor P [N, descriptor_dim()] of one pose (pose [48], its LBS and the Gaussians'
  // LBS-only positions, as pose() computes them); the virtual bones it used go to *bones.
  torch::Tensor compute_descriptor(const torch::Tensor& pose, const LbsOutput& lbs,
                                   const torch::Tensor& lbs_means, VirtualBones* bones);

  // What the decoders see of P [N, descriptor_dim()]: P itself, or with scs.input_norm = rest
  // (P - mean) * scale per dimension, the statistics fixed at construction.
  torch::Tensor decoder_view(const torch::Tensor& descriptor) const;

  // Network parameters by group name: "generator", "decoders", "gates".
  std::vector<std::pair<std::string, std::vector<torch::Tensor>>> network_parameter_groups();

 private:
  bool uses_static_bones() const;
  const FrozenDecoders& frozen_decoders();  // built or rebuilt when not current

  AvatarConfig config_;
  Rig rig_;
  BoneTopology topology_;
  GaussianState gaussians_;
  VirtualBoneGenerator generator_{nullptr};
  OffsetDecoders decoders_{nullptr};
  std::optional<FrozenDecoders> frozen_;
  torch::Tensor rest_normals_;  // [V, 3] float64 outward normals of the rig's template vertices
  // scs.input_norm = rest: the decoders see (P - descriptor_mean_) * descriptor_scale_, both
  // [descriptor_dim()] float32, fixed at construction (recomputed, not stored, on loading: they
  // depend only on the config, the rig and the seeded initial generator).
  torch::Tensor descriptor_mean_, descriptor_scale_;
};

// Upper triangle [N, 6] of symmetric matrices [N, 3, 3].
torch::Tensor symmetric_upper(const torch::Tensor& m);

}  // namespace handscs
