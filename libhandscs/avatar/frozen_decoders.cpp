#include "avatar/frozen_decoders.h"

#include <torch/types.h>

#include "avatar/linear_relu.h"

namespace handscs {

namespace {

// Every tensor the frozen values depend on, in a fixed order.
std::vector<torch::Tensor> source_tensors(OffsetDecodersImpl& decoders, const torch::Tensor& eg,
                                          const torch::Tensor& ea) {
  std::vector<torch::Tensor> out = decoders.parameters();
  out.push_back(eg);
  out.push_back(ea);
  return out;
}

std::vector<std::pair<const void*, int64_t>> fingerprint(const std::vector<torch::Tensor>& tensors) {
  std::vector<std::pair<const void*, int64_t>> out;
  for (const auto& t : tensors)
    out.emplace_back(t.unsafeGetTensorImpl(), static_cast<int64_t>(t._version()));
  return out;
}

}  // namespace

FrozenDecoders::FrozenDecoders(OffsetDecodersImpl& decoders, const torch::Tensor& embed_geometry,
                               const torch::Tensor& embed_appearance) {
  torch::NoGradGuard no_grad;
  sources_ = fingerprint(source_tensors(decoders, embed_geometry, embed_appearance));
  const int64_t p = decoders.descriptor_dim();
  geometry_ = freeze(*decoders.geometry, embed_geometry, p);
  appearance_ = freeze(*decoders.appearance, embed_appearance, p);
  fusion_ = freeze(*decoders.fusion, torch::cat({embed_geometry, embed_appearance}, 1), p);
}

bool FrozenDecoders::current(OffsetDecodersImpl& decoders, const torch::Tensor& embed_geometry,
                             const torch::Tensor& embed_appearance) const {
  return fingerprint(source_tensors(decoders, embed_geometry, embed_appearance)) == sources_;
}

FrozenDecoders::Mlp FrozenDecoders::freeze(GatedMlpImpl& mlp, const torch::Tensor& embeddings,
                                           int64_t descriptor_dim) {
  // Layer 1's columns: [descriptor (|P|), embeddings (e), vec(T) (12)].
  const auto w = mlp.layer(0)->weight.detach();
  const int64_t p = descriptor_dim, e = embeddings.size(1);
  Mlp out;
  out.w1 = torch::cat({w.slice(1, 0, p), w.slice(1, p + e)}, 1);
  // Computed in the parameters' precision (float), whatever the decoders run in.
  out.per_gaussian1 = embeddings.detach().matmul(w.slice(1, p, p + e).t()) + mlp.layer(0)->bias.detach();
  out.w2 = mlp.layer(1)->weight.detach();
  out.b2 = mlp.layer(1)->bias.detach();
  const auto gate = mlp.gate.detach();
  out.w3 = mlp.layer(2)->weight.detach() * gate;
  out.b3 = mlp.layer(2)->bias.detach() * gate;
  const bool bf16 = mlp.bf16() && w.scalar_type() == torch::kFloat;  // as GatedMlp::forward
  // b2 stays in the parameters' precision: in bf16 it is added after the GEMM, in float.
  for (auto* t : {&out.w1, &out.per_gaussian1, &out.w2, &out.w3, &out.b3})
    *t = (bf16 ? t->to(torch::kBFloat16) : *t).contiguous();
  out.b2 = out.b2.contiguous();
  out.bias_after_gemm = bf16;
  return out;
}

torch::Tensor FrozenDecoders::run(const Mlp& mlp, const torch::Tensor& x,
                                  const torch::Tensor& rows) const {
  const auto constant = rows.defined() ? mlp.per_gaussian1.index_select(0, rows) : mlp.per_gaussian1;
  if (mlp.bias_after_gemm) {  // as GatedMlp::forward in bf16
    auto h = torch::mm(x, mlp.w1.t());
    add_bias_relu_(h, constant);
    auto h2 = torch::mm(h, mlp.w2.t());
    add_bias_relu_(h2, mlp.b2);
    return torch::addmm(mlp.b3, h2, mlp.w3.t());
  }
  auto h = torch::addmm(constant, x, mlp.w1.t()).relu_();
  h = torch::addmm(mlp.b2, h, mlp.w2.t()).relu_();
  return torch::addmm(mlp.b3, h, mlp.w3.t());
}

DecoderOutputs FrozenDecoders::outputs(const torch::Tensor& descriptor, const torch::Tensor& transforms,
                                       const torch::Tensor& rows) const {
  torch::NoGradGuard no_grad;
  const auto dtype = transforms.scalar_type();
  auto x = torch::cat({descriptor, transforms}, 1);
  if (geometry_.w1.scalar_type() != dtype) x = x.to(geometry_.w1.scalar_type());
  auto output = [&](const Mlp& mlp) { return run(mlp, x, rows).to(dtype); };
  return {output(geometry_), output(appearance_), output(fusion_)};
}

DecodedOffsets FrozenDecoders::forward(const torch::Tensor& descriptor,
                                       const torch::Tensor& transforms) const {
  const auto out = outputs(descriptor, transforms);
  return offsets_from_outputs(out.geometry, out.appearance, out.fusion);
}

}  // namespace handscs
