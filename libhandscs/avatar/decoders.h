// Offset decoders (paper §3.1.3): geometry [P, e_g, vec(T)] -> dx, dSigma; appearance
// [P, e_a, vec(T)] -> dc; fusion [P, e_g, e_a, vec(T)] -> dx^f, dSigma^f, dc^f. Each is
// Linear-ReLU-Linear-ReLU-Linear times a learnable scalar gate initialised to 0, so the avatar
// starts as plain LBS. dSigma = R(q) diag(exp(s)) R(q)^T with q = (1,0,0,0) + raw: SPD, = I at zero.
#pragma once

#include <torch/nn/module.h>
#include <torch/nn/modules/linear.h>
#include <torch/nn/pimpl.h>

namespace handscs {

// One gated MLP: gate * L3(relu(L2(relu(L1(x))))). With bf16 set, a float or bfloat16 input runs
// its matmuls in bfloat16 (float accumulation) and returns float, the hidden layers adding their
// float bias after the GEMM (avatar/linear_relu.h); other dtypes are computed as they come.
class GatedMlpImpl : public torch::nn::Module {
 public:
  GatedMlpImpl(int64_t inputs, int64_t hidden, int64_t outputs, bool bf16 = false);
  torch::Tensor forward(const torch::Tensor& x);  // [N, inputs] -> [N, outputs]
  torch::Tensor gate;                             // [1], starts at 0
  const torch::nn::Linear& layer(int k) const { return k == 0 ? layer1_ : k == 1 ? layer2_ : layer3_; }
  bool bf16() const { return bf16_; }

 private:
  torch::nn::Linear layer1_{nullptr}, layer2_{nullptr}, layer3_{nullptr};
  bool bf16_;
};
TORCH_MODULE(GatedMlp);

struct DecodedOffsets {
  torch::Tensor dx;        // [N, 3] geometry position offset
  torch::Tensor dsigma;    // [N, 3, 3] geometry covariance factor (SPD)
  torch::Tensor dc;        // [N, 3] appearance colour offset
  torch::Tensor dx_f;      // [N, 3] fusion position offset
  torch::Tensor dsigma_f;  // [N, 3, 3] fusion covariance factor (SPD)
  torch::Tensor dc_f;      // [N, 3] fusion colour offset
};

// The three decoders' raw outputs: geometry [N, 10], appearance [N, 3], fusion [N, 13].
struct DecoderOutputs {
  torch::Tensor geometry, appearance, fusion;
};

class OffsetDecodersImpl : public torch::nn::Module {
 public:
  // descriptor_dim = |P| (0 without SCS), embedding_dim = d (0 without embeddings), bf16 as in
  // GatedMlp.
  OffsetDecodersImpl(int64_t descriptor_dim, int64_t embedding_dim, int64_t hidden, bool bf16);

  // descriptor [N, |P|] (may be empty), e_g, e_a [N, d], transforms [N, 12] = vec of the 3x4 T.
  DecodedOffsets forward(const torch::Tensor& descriptor, const torch::Tensor& embed_geometry,
                         const torch::Tensor& embed_appearance, const torch::Tensor& transforms);

  // The raw outputs forward() builds its offsets from (for callers that compute dSigma and
  // dSigma^f themselves, avatar/covariance_chain.h).
  DecoderOutputs outputs(const torch::Tensor& descriptor, const torch::Tensor& embed_geometry,
                         const torch::Tensor& embed_appearance, const torch::Tensor& transforms);

  GatedMlp geometry{nullptr}, appearance{nullptr}, fusion{nullptr};
  int64_t descriptor_dim() const { return descriptor_dim_; }  // |P|, the first inputs

 private:
  int64_t descriptor_dim_;
};
TORCH_MODULE(OffsetDecoders);

// The offsets from the three decoders' raw outputs: geometry [N, 10], appearance [N, 3], fusion
// [N, 13]; dSigma and dSigma^f by spd_from_raw of their spd_raw columns, or given (computed from
// those columns elsewhere, e.g. avatar/covariance_chain.h).
DecodedOffsets offsets_from_outputs(const torch::Tensor& geometry, const torch::Tensor& appearance,
                                    const torch::Tensor& fusion);
DecodedOffsets offsets_from_outputs(const torch::Tensor& geometry, const torch::Tensor& appearance,
                                    const torch::Tensor& fusion, const torch::Tensor& dsigma,
                                    const torch::Tensor& dsigma_f);

// The 7 raw values [N, 7] of the SPD factor in a geometry or fusion output.
torch::Tensor spd_raw(const torch::Tensor& output);

// SPD factor from 7 raw values [N, 7] = (log-scales 3, quaternion delta 4): R diag(exp(s)) R^T.
torch::Tensor spd_from_raw(const torch::Tensor& raw);

}  // namespace handscs
