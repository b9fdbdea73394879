#include "scs/virtual_bones.h"

#include <torch/types.h>

#include "hand/rig.h"

namespace handscs {

namespace {
// Output layout per bone: [w^s (E), w^e (E), t^s (E), t^e (E), dp (3), dq (3)].
int64_t outputs_per_bone(int64_t num_static) { return 4 * num_static + 6; }
}  // namespace

VirtualBoneGeneratorImpl::VirtualBoneGeneratorImpl(const ScsConfig& config,
                                                   const BoneTopology& topology)
    : num_bones_(config.virtual_bones),
      num_static_(topology.size()),
      interpolation_(config.interpolation),
      endpoint_offsets_(config.endpoint_offsets),
      max_offset_(config.max_offset) {
  const int64_t input = kPoseDim + 3 * kJoints21;
  const int64_t hidden = config.generator_hidden;
  layer1_ = register_module("layer1", torch::nn::Linear(input, hidden));
  layer2_ = register_module("layer2", torch::nn::Linear(hidden, hidden));
  head_ = register_module("head", torch::nn::Linear(hidden, num_bones_ * outputs_per_bone(num_static_)));
  kernel_ = register_buffer("kernel", topology.kernel.clone());
  // Index tensors are plain members, not buffers: Module::to(dtype) would convert them to floats.
  u_ = topology.u.clone();
  v_ = topology.v.clone();
  torch::NoGradGuard no_grad;
  // Small head weights: the bones start from their bias (a fixed random layout) and the pose input
  // perturbs them gently. Random attention logits (std 2) spread the M bones over different static
  // bones, so their descriptors are not identical at the start.
  head_->weight.normal_(0.0, 1e-3);
  head_->bias.normal_(0.0, 2.0);
  auto bias = head_->bias.view({num_bones_, outputs_per_bone(num_static_)});
  bias.slice(1, 2 * num_static_, 4 * num_static_).normal_(0.0, 1.0);  // t logits around 0.5
  bias.slice(1, 4 * num_static_).zero_();                            // offsets start at zero
}

VirtualBones VirtualBoneGeneratorImpl::forward(const torch::Tensor& pose,
                                               const torch::Tensor& network_joints,
                                               const torch::Tensor& basis_joints) {
  TORCH_CHECK(pose.numel() == kPoseDim, "VirtualBoneGenerator: pose must have 48 values, got ",
              pose.sizes());
  TORCH_CHECK(network_joints.sizes() == torch::IntArrayRef({kJoints21, 3}) &&
                  basis_joints.sizes() == torch::IntArrayRef({kJoints21, 3}),
              "VirtualBoneGenerator: joints must be [21, 3], got ", network_joints.sizes(),
              " and ", basis_joints.sizes());
  const int64_t E = num_static_;
  auto input = torch::cat({pose.reshape({-1}), network_joints.reshape({-1})}).to(layer1_->weight.dtype());
  auto h = torch::relu(layer1_->forward(input));
  h = torch::relu(layer2_->forward(h));
  auto out = head_->forward(h).view({num_bones_, outputs_per_bone(E)});

  VirtualBones bones;
  auto smooth = [&](const torch::Tensor& logits) {
    auto k = torch::softmax(logits, -1).matmul(kernel_.t());  // (K sigma(w)) per row
    return k / k.sum(-1, /*keepdim=*/true);                   // L1 normalisation (entries >= 0)
  };
  bones.start_weights = smooth(out.slice(1, 0, E));
  bones.end_weights = smooth(out.slice(1, E, 2 * E));
  if (interpolation_) {
    bones.start_t = torch::sigmoid(out.slice(1, 2 * E, 3 * E));
    bones.end_t = torch::sigmoid(out.slice(1, 3 * E, 4 * E));
  } else {
    bones.start_t = torch::full({num_bones_, E}, 0.5, out.options());
    bones.end_t = bones.start_t;
  }
  const auto joints = basis_joints.to(out.dtype());
  const auto ju = joints.index_select(0, u_);  // [E, 3]
  const auto jv = joints.index_select(0, v_);  // [E, 3]
  // sum_b w_b [(1 - t_b) j_u + t_b j_v] = (w (1 - t)) j_u + (w t) j_v
  auto endpoint = [&](const torch::Tensor& w, const torch::Tensor& t) {
    return (w * (1 - t)).matmul(ju) + (w * t).matmul(jv);
  };
  bones.start = endpoint(bones.start_weights, bones.start_t);
  bones.end = endpoint(bones.end_weights, bones.end_t);
  if (endpoint_offsets_) {
    bones.start = bones.start + max_offset_ * torch::tanh(out.slice(1, 4 * E, 4 * E + 3));
    bones.end = bones.end + max_offset_ * torch::tanh(out.slice(1, 4 * E + 3, 4 * E + 6));
  }
  return bones;
}

}  // namespace handscs
