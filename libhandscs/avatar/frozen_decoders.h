// The offset decoders of one avatar at inference. With the weights and the embeddings
// fixed, each decoder's first layer W [P, e, vec(T)] + b splits into W_P P + W_T vec(T), which
// changes with the pose, and W_e e + b, a constant per Gaussian: that part is computed once, in
// float, and kept in the decoders' precision. The weights are cast to bf16 once (in bf16 the hidden
// layers' biases are added after the GEMMs, avatar/linear_relu.h) and each gate is folded into its
// last layer. The same function as OffsetDecoders::forward up to rounding (bounded by
// tests/avatar/test_frozen_decoders; docs/BENCHMARKS.md#rendering-a-novel-pose).
//
// A FrozenDecoders remembers which tensors it was built from and their version counters, so
// current() notices any in-place update (an optimiser step) or replacement (densification).
#pragma once

#include <vector>

#include <torch/types.h>

#include "avatar/decoders.h"

namespace handscs {

class FrozenDecoders {
 public:
  FrozenDecoders(OffsetDecodersImpl& decoders, const torch::Tensor& embed_geometry,
                 const torch::Tensor& embed_appearance);

  // descriptor [N, |P|] (may be empty), transforms [N, 12]; as OffsetDecoders::forward.
  DecodedOffsets forward(const torch::Tensor& descriptor, const torch::Tensor& transforms) const;

  // The three decoders' raw outputs in the transforms' dtype, for callers that build the offsets
  // themselves (avatar/covariance_chain.h). rows [K] int64: descriptor and transforms are those
  // Gaussians' rows only (a cull, avatar/facing_cull.h); undefined: every Gaussian, in order.
  DecoderOutputs outputs(const torch::Tensor& descriptor, const torch::Tensor& transforms,
                         const torch::Tensor& rows = {}) const;

  // Whether decoders and embeddings are still the tensors, with the values, this was built from.
  bool current(OffsetDecodersImpl& decoders, const torch::Tensor& embed_geometry,
               const torch::Tensor& embed_appearance) const;

 private:
  struct Mlp {
    torch::Tensor w1, per_gaussian1;  // [hidden, |P| + 12] pose part; [N, hidden] = W_e e + b1
    torch::Tensor w2, b2, w3, b3;     // gate folded into w3, b3; b2 in the parameters' precision
    bool bias_after_gemm = false;     // bf16 from float parameters: add_bias_relu_ after plain mm
  };
  // descriptor_dim: |P|, the first columns of layer 1 (then the embeddings, then vec(T)).
  static Mlp freeze(GatedMlpImpl& mlp, const torch::Tensor& embeddings, int64_t descriptor_dim);
  torch::Tensor run(const Mlp& mlp, const torch::Tensor& x, const torch::Tensor& rows) const;

  Mlp geometry_, appearance_, fusion_;
  // (tensor, version) of every input the frozen values were computed from.
  std::vector<std::pair<const void*, int64_t>> sources_;
};

}  // namespace handscs
