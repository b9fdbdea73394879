#include "infer/feature_sets.h"

#include "core/error.h"
#include "hand/joint_order.h"
#include "hand/rig.h"

namespace handscs {

const char* feature_set_name(FeatureSet set) {
  switch (set) {
    case FeatureSet::position: return "position";
    case FeatureSet::embedding: return "embedding";
    case FeatureSet::transform: return "transform";
    case FeatureSet::descriptor: return "descriptor";
    case FeatureSet::descriptor_static: return "descriptor_static";
    case FeatureSet::descriptor_virtual: return "descriptor_virtual";
    case FeatureSet::decoder_input: return "decoder_input";
  }
  throw Error("feature_set_name: unknown feature set (programming error)");
}

const torch::Tensor& GaussianFeatures::get(FeatureSet set) const {
  switch (set) {
    case FeatureSet::position: return position;
    case FeatureSet::embedding: return embedding;
    case FeatureSet::transform: return transform;
    case FeatureSet::descriptor: return descriptor;
    case FeatureSet::descriptor_static: return descriptor_static;
    case FeatureSet::descriptor_virtual: return descriptor_virtual;
    case FeatureSet::decoder_input: return decoder_input;
  }
  throw Error("GaussianFeatures::get: unknown feature set (programming error)");
}

torch::Tensor blend_transform_vectors(const torch::Tensor& skin_weights, const torch::Tensor& joint_transforms) {
  TORCH_CHECK(skin_weights.dim() == 2 && skin_weights.size(1) == kRigJoints,
              "blend_transform_vectors: skin_weights must be [N, 16], got ", skin_weights.sizes());
  TORCH_CHECK(joint_transforms.sizes() == torch::IntArrayRef({kRigJoints, 4, 4}),
              "blend_transform_vectors: joint_transforms must be [16, 4, 4], got ", joint_transforms.sizes());
  // The same product and slice as Avatar::pose (avatar/avatar.cpp): rows 0-2 of each 4x4, row-major.
  const auto t = skin_weights.matmul(joint_transforms.reshape({kRigJoints, 16}).to(skin_weights.dtype()));
  return t.view({-1, 4, 4}).slice(1, 0, 3).reshape({-1, 12});
}

torch::Tensor phalange_labels(const torch::Tensor& skin_weights) {
  TORCH_CHECK(skin_weights.dim() == 2 && skin_weights.size(1) == kRigJoints,
              "phalange_labels: skin_weights must be [N, 16], got ", skin_weights.sizes());
  return skin_weights.argmax(1);
}

std::vector<std::string> phalange_names() {
  return {kMano21Names.begin(), kMano21Names.begin() + kRigJoints};
}

GaussianFeatures gaussian_features(Avatar& avatar, const torch::Tensor& pose, const torch::Tensor& shape,
                                   const torch::Tensor& trans) {
  const AvatarState state = avatar.pose(pose, shape, trans, /*need_descriptor=*/true);
  const GaussianState& g = avatar.gaussians();
  const auto f64 = [](const torch::Tensor& t) { return t.detach().to(torch::kFloat64).contiguous(); };
  GaussianFeatures f;
  f.position = f64(state.lbs_means);
  f.embedding = f64(torch::cat({g.embed_geometry.detach(), g.embed_appearance.detach()}, 1));
  f.transform = f64(blend_transform_vectors(g.skin_weights.detach(), state.lbs.joint_transforms[0]));
  f.descriptor = f64(state.descriptor);
  const int64_t virtual_bones = avatar.generator() ? avatar.generator()->num_bones() : 0;
  const int64_t static_bones = f.descriptor.size(1) - virtual_bones;
  f.descriptor_static = f.descriptor.slice(1, 0, static_bones);
  f.descriptor_virtual = f.descriptor.slice(1, static_bones);
  const bool scs = avatar.config().scs.enabled && f.descriptor.size(1) > 0;
  f.decoder_input = scs ? torch::cat({f.descriptor, f.embedding, f.transform}, 1)
                        : torch::cat({f.embedding, f.transform}, 1);
  f.labels = phalange_labels(g.skin_weights.detach()).contiguous();
  f.posed = {state.posed.means.detach(), state.posed.covariances.detach(), state.posed.colors.detach(),
             state.posed.opacities.detach()};
  return f;
}

}  // namespace handscs
