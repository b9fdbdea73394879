#include "avatar/avatar.h"

#include <torch/types.h>

#include "avatar/covariance_chain.h"
#include "core/error.h"
#include "core/threads.h"
#include "hand/lbs_one_pose.h"
#include "scs/descriptor.h"

namespace handscs {

torch::Tensor symmetric_upper(const torch::Tensor& m) {
  return torch::stack({m.select(-2, 0).select(-1, 0), m.select(-2, 0).select(-1, 1),
                       m.select(-2, 0).select(-1, 2), m.select(-2, 1).select(-1, 1),
                       m.select(-2, 1).select(-1, 2), m.select(-2, 2).select(-1, 2)},
                      -1);
}

Avatar::Avatar(const AvatarConfig& config, Rig rig)
    : config_(config), rig_(std::move(rig)), topology_(make_static_topology(config.scs)) {
  torch::manual_seed(static_cast<uint64_t>(config.seed));
  gaussians_ = init_gaussians_from_rig(rig_, config_);
  rest_normals_ = rest_vertex_normals(rig_);
  if (config_.scs.enabled && config_.scs.virtual_bones > 0)
    generator_ = VirtualBoneGenerator(config_.scs, topology_);
  const int64_t embedding = config_.embeddings ? config_.embedding_dim : 0;
  const bool bf16 = config_.decoder_precision == AvatarConfig::DecoderPrecision::bf16 ||
                    (config_.decoder_precision == AvatarConfig::DecoderPrecision::automatic &&
                     has_native_bf16_matmul());
  decoders_ = OffsetDecoders(config_.scs.enabled ? descriptor_dim() : 0, embedding,
                             config_.decoder_hidden, bf16);
  if (config_.scs.enabled && config_.scs.input_norm == ScsConfig::InputNorm::rest &&
      descriptor_dim() > 0) {
    // P of the initial Gaussians (the rig's vertices) in the zero pose, without the decoders'
    // view applied (the statistics are not set yet).
    torch::NoGradGuard no_grad;
    const auto zero = torch::zeros({kPoseDim});
    const AvatarState rest = pose(zero, torch::zeros({kShapeDim}), torch::zeros({3}), true);
    descriptor_mean_ = rest.descriptor.mean(0).to(torch::kFloat32);
    // The floor keeps a dimension that is constant at rest (never seen so far) from being blown
    // up: P's values are O(0.01-1) (unitless static terms, metres for the virtual ones).
    constexpr double kStdFloor = 1e-4;
    descriptor_scale_ = (config_.embedding_init_std /
                         rest.descriptor.std(0).clamp_min(kStdFloor)).to(torch::kFloat32);
  }
}

bool Avatar::uses_static_bones() const {
  // Without SCS the decoders see no P, but the inter-pose loss still matches Gaussians by their
  // static-bone coordinates (the virtual bones would have no training signal).
  return config_.scs.static_bones || !config_.scs.enabled;
}

int64_t Avatar::descriptor_dim() const {
  return (uses_static_bones() ? topology_.size() : 0) +
         (generator_ ? generator_->num_bones() : 0);
}

std::vector<std::pair<std::string, std::vector<torch::Tensor>>> Avatar::network_parameter_groups() {
  std::vector<torch::Tensor> decoder_weights, gates;
  for (const auto& item : decoders_->named_parameters()) {
    if (item.key().find("gate") != std::string::npos)
      gates.push_back(item.value());
    else
      decoder_weights.push_back(item.value());
  }
  std::vector<std::pair<std::string, std::vector<torch::Tensor>>> groups;
  if (generator_) groups.push_back({"generator", generator_->parameters()});
  groups.push_back({"decoders", decoder_weights});
  groups.push_back({"gates", gates});
  return groups;
}

torch::Tensor Avatar::compute_descriptor(const torch::Tensor& pose, const LbsOutput& lbs,
                                         const torch::Tensor& lbs_means, VirtualBones* bones) {
  require(bones != nullptr, "Avatar::compute_descriptor: bones must point to a VirtualBones");
  std::vector<torch::Tensor> parts;
  // scs.detach_means: P's gradient reaches the generator (and the joints), not the means.
  const bool detach = config_.scs.detach_means;
  const torch::Tensor& means_in = detach ? lbs_means.detach() : lbs_means;
  const auto posed_joints = lbs.joints[0];      // [21, 3]
  const auto canonical_joints = lbs.rest_joints[0];
  if (uses_static_bones()) {
    // One pass over the Gaussians, with its own backward under autograd (scs/descriptor.h).
    parts.push_back(
        static_descriptor_loop(means_in, posed_joints, topology_, config_.scs.tau, config_.scs.norm_eps));
  }
  if (generator_) {
    const bool posed_space = config_.scs.virtual_space == ScsConfig::VirtualSpace::posed;
    *bones = generator_->forward(pose, canonical_joints, posed_space ? posed_joints : canonical_joints);
    // Canonical space is the shaped rest hand, the space of rest_joints and so of the bones: the
    // Gaussians' template centres get their rig vertex's shape offset (not the pose offset).
    const auto means = detach ? gaussians_.means.detach() : gaussians_.means;
    const auto centres =
        posed_space ? means_in : means + lbs.shape_offsets[0].index_select(0, gaussians_.vertex_ids);
    parts.push_back(virtual_descriptor(centres, bones->start, bones->end, config_.scs.norm_eps));
  }
  if (parts.empty()) return torch::zeros({gaussians_.size(), 0}, lbs_means.options());
  return torch::cat(parts, 1);
}

torch::Tensor Avatar::decoder_view(const torch::Tensor& descriptor) const {
  if (!descriptor_scale_.defined()) return descriptor;
  const auto dtype = descriptor.scalar_type();
  return (descriptor - descriptor_mean_.to(dtype)) * descriptor_scale_.to(dtype);
}

void Avatar::share_decoders(Avatar& other) {
  require(other.decoders_->descriptor_dim() == decoders_->descriptor_dim(),
          "model.shared_decoders: the hands' descriptors differ in width (" +
              std::to_string(other.decoders_->descriptor_dim()) + " against " +
              std::to_string(decoders_->descriptor_dim()) + ")");
  decoders_ = other.decoders_;
  frozen_.reset();
}

const FrozenDecoders& Avatar::frozen_decoders() {
  const auto& g = gaussians_;
  if (!frozen_ || !frozen_->current(*decoders_, g.embed_geometry, g.embed_appearance))
    frozen_.emplace(*decoders_, g.embed_geometry, g.embed_appearance);
  return *frozen_;
}

AvatarState Avatar::pose(const torch::Tensor& pose_in, const torch::Tensor& shape_in,
                         const torch::Tensor& trans_in, bool need_descriptor,
                         const FacingCull* cull) {
  require(pose_in.numel() == kPoseDim, "avatar: pose must have 48 values, got " +
                                           std::to_string(pose_in.numel()));
  require(shape_in.numel() == kShapeDim, "avatar: shape must have 10 values, got " +
                                             std::to_string(shape_in.numel()));
  require(trans_in.numel() == 3, "avatar: trans must have 3 values, got " +
                                     std::to_string(trans_in.numel()));
  require(torch::isfinite(pose_in).all().item<bool>(), "avatar: pose contains NaN or Inf");
  require(torch::isfinite(shape_in).all().item<bool>(), "avatar: shape contains NaN or Inf");
  require(torch::isfinite(trans_in).all().item<bool>(), "avatar: trans contains NaN or Inf");
  const auto dtype = gaussians_.means.scalar_type();
  const auto pose = pose_in.to(dtype).reshape({1, kPoseDim});
  const auto shape = shape_in.to(dtype).reshape({1, kShapeDim});
  const auto trans = trans_in.to(dtype).reshape({1, 3});

  AvatarState s;
  // The skinning in plain loops (hand/lbs_one_pose.h, in double, rounded once) unless a gradient
  // must reach the pose, shape or translation (pose refinement): the rig itself is never learnt.
  // With refinement on, the skinning moves to lbs() at train.pose_refine.start, and its values by
  // float rounding with it (docs/BENCHMARKS.md#model-forward-and-backward).
  const LbsOptions lbs_options{config_.flat_hand_mean};
  const bool lbs_graph = torch::GradMode::is_enabled() &&
                         (pose.requires_grad() || shape.requires_grad() || trans.requires_grad());
  s.lbs = lbs_graph ? lbs(rig_, pose, shape, trans, lbs_options)
                    : lbs_one_pose(rig_, pose, shape, trans, lbs_options);
  auto& g = gaussians_;
  // Per-Gaussian blend transform T = sum_k w_k A_k and blend offset of the nearest rig vertex.
  const auto transforms =
      g.skin_weights.matmul(s.lbs.joint_transforms[0].reshape({kRigJoints, 16})).view({-1, 4, 4});
  const auto linear = transforms.slice(1, 0, 3).slice(2, 0, 3);  // [N, 3, 3]
  const auto offset = transforms.slice(1, 0, 3).select(2, 3);    // [N, 3]
  const auto blend = s.lbs.blend_offsets[0].index_select(0, g.vertex_ids);  // [N, 3]
  auto apply = [&](const torch::Tensor& x) {
    return linear.matmul((x + blend).unsqueeze(2)).squeeze(2) + offset;
  };
  s.lbs_means = apply(g.means);

  const bool use_descriptor = config_.scs.enabled && descriptor_dim() > 0;
  if (use_descriptor || need_descriptor)
    s.descriptor = compute_descriptor(pose[0], s.lbs, s.lbs_means, &s.virtual_bones);
  const auto descriptor_in = use_descriptor ? decoder_view(s.descriptor)
                                            : torch::zeros({g.size(), 0}, s.lbs_means.options());
  const auto transform_in = transforms.slice(1, 0, 3).reshape({-1, 12});
  if (cull) {
    // facing_rows takes the means' dtype.
    const auto rows = facing_rows(linear, rest_normals_.index_select(0, g.vertex_ids), s.lbs_means, *cull);
    if (rows.numel() < g.size()) s.decoded_rows = rows;
  }
  const bool culled = s.decoded_rows.defined();
  // Culled: the decoders see the kept rows only, and the others' outputs are zeros.
  const auto kept = [&](const torch::Tensor& t) { return culled ? t.index_select(0, s.decoded_rows) : t; };
  const auto all_rows = [&](const torch::Tensor& t) {
    return culled ? torch::zeros({g.size(), t.size(1)}, t.options()).index_copy(0, s.decoded_rows, t) : t;
  };
  // The decoders (frozen at inference: avatar/frozen_decoders.h), then the 3x3 chain in one pass,
  // with its own backward under autograd (avatar/covariance_chain.h).
  auto raw = torch::GradMode::is_enabled()
                 ? decoders_->outputs(kept(descriptor_in), kept(g.embed_geometry),
                                      kept(g.embed_appearance), kept(transform_in))
                 : frozen_decoders().outputs(kept(descriptor_in), kept(transform_in), s.decoded_rows);
  if (culled) raw = {all_rows(raw.geometry), all_rows(raw.appearance), all_rows(raw.fusion)};
  const auto chain =
      covariance_chain(g.rotations, g.log_scales, spd_raw(raw.geometry), spd_raw(raw.fusion), linear);
  s.offsets = offsets_from_outputs(raw.geometry, raw.appearance, raw.fusion, chain.dsigma, chain.dsigma_f);
  s.canonical_covariances = chain.canonical;
  s.posed.covariances = chain.posed_upper;
  s.canonical_means = g.means + s.offsets.dx + s.offsets.dx_f;
  s.canonical_colors = g.colors + s.offsets.dc + s.offsets.dc_f;
  s.posed.means = apply(s.canonical_means);
  s.posed.colors = s.canonical_colors;
  s.posed.opacities = torch::sigmoid(g.opacity_logits);
  if (culled)
    s.posed.opacities = s.posed.opacities *
                        torch::zeros_like(s.posed.opacities).index_fill_(0, s.decoded_rows, 1.0);
  return s;
}

void Avatar::set_dtype(torch::ScalarType dtype) {
  for (auto& [name, tensor] : gaussians_.all()) {
    if (!tensor->is_floating_point()) continue;
    const bool learn = tensor->requires_grad();
    *tensor = tensor->detach().to(dtype);
    if (learn) tensor->set_requires_grad(true);
  }
  if (generator_) generator_->to(dtype);
  decoders_->to(dtype);
  frozen_.reset();  // Module::to swaps parameter data (set_data), which the version check may miss
}

RasterOutput render_posed(const PosedGaussians& posed, const Camera& camera,
                          const RasterSettings& settings, const torch::Tensor& means2d_probe) {
  return rasterize_gaussians(posed.means, posed.covariances, posed.colors, posed.opacities, camera,
                             settings, means2d_probe);
}

PosedGaussians join_posed(const std::vector<const PosedGaussians*>& sets) {
  require(!sets.empty(), "join_posed: no posed Gaussians");
  if (sets.size() == 1) return *sets.front();
  const auto join = [&](torch::Tensor PosedGaussians::*field) {
    std::vector<torch::Tensor> parts;
    for (const PosedGaussians* set : sets) parts.push_back(set->*field);
    return torch::cat(parts, 0);
  };
  return {join(&PosedGaussians::means), join(&PosedGaussians::covariances),
          join(&PosedGaussians::colors), join(&PosedGaussians::opacities)};
}

AvatarOutput Avatar::forward(const torch::Tensor& pose_in, const torch::Tensor& shape,
                             const torch::Tensor& trans, const Camera& camera,
                             const RasterSettings& settings, const torch::Tensor& means2d_probe,
                             bool need_descriptor) {
  AvatarOutput out;
  out.state = pose(pose_in, shape, trans, need_descriptor);
  out.render = render_posed(out.state.posed, camera, settings, means2d_probe);
  return out;
}

}  // namespace handscs
