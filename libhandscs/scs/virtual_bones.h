// Virtual-bone generator (paper §3.1.1): an MLP of (theta, joints) predicts, for each of M bones,
// attention logits w^s, w^e over the static bones, interpolation factors t^s, t^e and offsets dp, dq:
//   w~ = K softmax(w) / |K softmax(w)|_1,   p = sum_b w~^s_b [(1 - t^s_b) j_u + t^s_b j_v] + dp
// (q likewise with the end parameters).
#pragma once

#include <torch/nn/module.h>
#include <torch/nn/modules/linear.h>
#include <torch/nn/pimpl.h>

#include "scs/scs_config.h"
#include "scs/topology.h"

namespace handscs {

struct VirtualBones {
  torch::Tensor start;          // [M, 3] endpoint p
  torch::Tensor end;            // [M, 3] endpoint q
  torch::Tensor start_weights;  // [M, E] smoothed attention over static bones (rows sum to 1)
  torch::Tensor end_weights;    // [M, E]
  torch::Tensor start_t;        // [M, E] interpolation factors in [0, 1]
  torch::Tensor end_t;          // [M, E]
};

class VirtualBoneGeneratorImpl : public torch::nn::Module {
 public:
  VirtualBoneGeneratorImpl(const ScsConfig& config, const BoneTopology& topology);

  // pose: [48] axis-angle; network_joints: [21, 3] joints fed to the MLP (canonical);
  // basis_joints: [21, 3] joints the endpoints are built from (canonical, or posed for the ablation).
  VirtualBones forward(const torch::Tensor& pose, const torch::Tensor& network_joints,
                       const torch::Tensor& basis_joints);

  int64_t num_bones() const { return num_bones_; }

 private:
  int64_t num_bones_;
  int64_t num_static_;
  bool interpolation_;
  bool endpoint_offsets_;
  double max_offset_;
  torch::Tensor kernel_;  // [E, E] buffer
  torch::Tensor u_, v_;   // [E] buffers
  torch::nn::Linear layer1_{nullptr}, layer2_{nullptr}, head_{nullptr};
};
TORCH_MODULE(VirtualBoneGenerator);

}  // namespace handscs
