#include "avatar/decoders.h"

#include <torch/types.h>

#include "avatar/decoder_inputs.h"
#include "avatar/gaussians.h"
#include "avatar/linear_relu.h"
#include "render/rotation.h"

namespace handscs {

namespace {
constexpr int64_t kTransformDim = 12;  // vec of the 3x4 blend transform T
constexpr int64_t kSpdRaw = 7;         // 3 log-scales + 4 quaternion-delta values
}  // namespace

GatedMlpImpl::GatedMlpImpl(int64_t inputs, int64_t hidden, int64_t outputs, bool bf16)
    : bf16_(bf16) {
  layer1_ = register_module("layer1", torch::nn::Linear(inputs, hidden));
  layer2_ = register_module("layer2", torch::nn::Linear(hidden, hidden));
  layer3_ = register_module("layer3", torch::nn::Linear(hidden, outputs));
  gate = register_parameter("gate", torch::zeros({1}));
}

torch::Tensor GatedMlpImpl::forward(const torch::Tensor& x) {
  const bool mixed = bf16_ && (x.scalar_type() == torch::kFloat || x.scalar_type() == torch::kBFloat16);
  if (!mixed) {
    auto h = torch::relu(layer1_->forward(x));
    h = torch::relu(layer2_->forward(h));
    return gate * layer3_->forward(h);
  }
  // Mixed precision: bf16 operands, float accumulation inside oneDNN, float master weights (the
  // casts are differentiable, so Adam updates float parameters). The hidden layers add their float
  // bias after the GEMM (avatar/linear_relu.h: faster than addmm's bias).
  const auto bf16 = [](const torch::Tensor& t) { return t.to(torch::kBFloat16); };
  auto h = linear_relu(bf16(x), bf16(layer1_->weight), layer1_->bias);
  h = linear_relu(h, bf16(layer2_->weight), layer2_->bias);
  return gate * torch::linear(h, bf16(layer3_->weight), bf16(layer3_->bias)).to(torch::kFloat);
}

OffsetDecodersImpl::OffsetDecodersImpl(int64_t descriptor_dim, int64_t embedding_dim,
                                       int64_t hidden, bool bf16)
    : descriptor_dim_(descriptor_dim) {
  geometry = register_module(
      "geometry",
      GatedMlp(descriptor_dim + embedding_dim + kTransformDim, hidden, 3 + kSpdRaw, bf16));
  appearance = register_module(
      "appearance", GatedMlp(descriptor_dim + embedding_dim + kTransformDim, hidden, 3, bf16));
  fusion = register_module("fusion", GatedMlp(descriptor_dim + 2 * embedding_dim + kTransformDim,
                                              hidden, 3 + kSpdRaw + 3, bf16));
}

torch::Tensor spd_from_raw(const torch::Tensor& raw) {
  const auto log_scales = raw.slice(1, 0, 3);
  auto quats = raw.slice(1, 3, 7).clone();
  quats.select(1, 0).add_(1.0);  // q = (1, 0, 0, 0) + raw: identity rotation when raw = 0
  const auto rot = quaternion_to_matrix(quats);               // [N, 3, 3]
  const auto scaled = rot * torch::exp(log_scales).unsqueeze(1);  // R diag(exp(s))
  return scaled.matmul(rot.transpose(1, 2));
}

DecoderOutputs OffsetDecodersImpl::outputs(const torch::Tensor& descriptor,
                                           const torch::Tensor& embed_geometry,
                                           const torch::Tensor& embed_appearance,
                                           const torch::Tensor& transforms) {
  const bool all_float = descriptor.scalar_type() == torch::kFloat && embed_geometry.scalar_type() == torch::kFloat &&
                         embed_appearance.scalar_type() == torch::kFloat && transforms.scalar_type() == torch::kFloat;
  if (geometry->bf16() && all_float) {
    // The bf16 inputs in one pass (the same values and gradients as the casts of the cats below).
    const auto in = bf16_decoder_inputs(descriptor, embed_geometry, embed_appearance, transforms);
    return {geometry->forward(in.geometry), appearance->forward(in.appearance), fusion->forward(in.fusion)};
  }
  const auto geometry_in = torch::cat({descriptor, embed_geometry, transforms}, 1);
  const auto appearance_in = torch::cat({descriptor, embed_appearance, transforms}, 1);
  const auto fusion_in = torch::cat({descriptor, embed_geometry, embed_appearance, transforms}, 1);
  return {geometry->forward(geometry_in), appearance->forward(appearance_in), fusion->forward(fusion_in)};
}

DecodedOffsets OffsetDecodersImpl::forward(const torch::Tensor& descriptor,
                                           const torch::Tensor& embed_geometry,
                                           const torch::Tensor& embed_appearance,
                                           const torch::Tensor& transforms) {
  const auto raw = outputs(descriptor, embed_geometry, embed_appearance, transforms);
  return offsets_from_outputs(raw.geometry, raw.appearance, raw.fusion);
}

torch::Tensor spd_raw(const torch::Tensor& output) { return output.slice(1, 3, 3 + kSpdRaw); }

DecodedOffsets offsets_from_outputs(const torch::Tensor& g, const torch::Tensor& a,
                                    const torch::Tensor& f) {
  return offsets_from_outputs(g, a, f, spd_from_raw(spd_raw(g)), spd_from_raw(spd_raw(f)));
}

DecodedOffsets offsets_from_outputs(const torch::Tensor& g, const torch::Tensor& a,
                                    const torch::Tensor& f, const torch::Tensor& dsigma,
                                    const torch::Tensor& dsigma_f) {
  DecodedOffsets out;
  out.dx = g.slice(1, 0, 3);
  out.dsigma = dsigma;
  out.dc = a;
  out.dx_f = f.slice(1, 0, 3);
  out.dsigma_f = dsigma_f;
  out.dc_f = f.slice(1, 3 + kSpdRaw, 6 + kSpdRaw);
  return out;
}

}  // namespace handscs
