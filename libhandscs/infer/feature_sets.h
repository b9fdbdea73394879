// The per-Gaussian features whose structure the paper pictures (Fig. 1(b), Fig. 7), for one pose:
// the embeddings [e_g, e_a], the blend transform vec(T) (T = sum_k w_k A_k), the structural
// coordinate P, and the fusion decoder's input built from them; each Gaussian labelled by its
// phalange, the argmax of its 16 skinning weights (MANO joint order, hand/joint_order.h).
#pragma once

#include <array>
#include <string>
#include <vector>

#include <torch/types.h>

#include "avatar/avatar.h"

namespace handscs {

// The feature sets compared, in the order of every table and file.
// P's static-bone and virtual-bone parts are also scored alone (which part is pose-consistent).
enum class FeatureSet {
  position, embedding, transform, descriptor, descriptor_static, descriptor_virtual, decoder_input
};
constexpr std::array<FeatureSet, 7> kFeatureSets = {
    FeatureSet::position,          FeatureSet::embedding,          FeatureSet::transform,
    FeatureSet::descriptor,        FeatureSet::descriptor_static,  FeatureSet::descriptor_virtual,
    FeatureSet::decoder_input};
// "position", "embedding", "transform", "descriptor", "descriptor_static", "descriptor_virtual",
// "decoder_input" (file and column names).
const char* feature_set_name(FeatureSet set);

struct GaussianFeatures {
  // All float64, detached. N = the avatar's Gaussians.
  torch::Tensor position;       // [N, 3] LBS-posed centres x'_lbs: a reference, where each Gaussian is
  torch::Tensor embedding;      // [N, 2d] [e_g, e_a]; the same in every pose ([N, 0] without embeddings)
  torch::Tensor transform;      // [N, 12] vec(T): rows 0-2 of T row-major, the decoders' 12 inputs
  torch::Tensor descriptor;     // [N, |P|] P, static then virtual bones; computed also when the
                                // decoders do not read it (SCS off: static bones only)
  torch::Tensor descriptor_static;   // [N, |E_s|] its static-bone columns ([N, 0] without static bones)
  torch::Tensor descriptor_virtual;  // [N, M] its virtual-bone columns ([N, 0] without virtual bones)
  torch::Tensor decoder_input;  // [N, I] the fusion decoder's input: [P, e_g, e_a, vec(T)] with SCS,
                                // [e_g, e_a, vec(T)] without (avatar/decoder_inputs.h)
  torch::Tensor labels;         // [N] int64 phalange label in 0..15
  PosedGaussians posed;         // the posed Gaussians as the avatar renders them

  const torch::Tensor& get(FeatureSet set) const;
};

// Runs the avatar's forward for one pose (pose [48], shape [10], trans [3]) with the descriptor
// forced on, and collects its features. Call without autograd (inference mode).
GaussianFeatures gaussian_features(Avatar& avatar, const torch::Tensor& pose, const torch::Tensor& shape,
                                   const torch::Tensor& trans);

// vec(T) of T = sum_k w_k A_k, as Avatar::pose builds the decoders' transform input.
torch::Tensor blend_transform_vectors(const torch::Tensor& skin_weights,       // [N, 16]
                                      const torch::Tensor& joint_transforms);  // [16, 4, 4]

// argmax over the 16 skinning weights (the first joint on ties).
torch::Tensor phalange_labels(const torch::Tensor& skin_weights);  // [N, 16] -> [N] int64

// The 16 labels' names for legends: the MANO joint names ("wrist", "index1", ...).
std::vector<std::string> phalange_names();

}  // namespace handscs
