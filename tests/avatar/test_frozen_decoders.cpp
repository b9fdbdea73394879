// avatar/frozen_decoders.h: the inference form of the decoders equals OffsetDecoders::forward
// (to rounding in double; to bf16 rounding in the bf16 path), with and without embeddings and SCS,
// and an Avatar posed without autograd follows every in-place update and replacement of its
// weights and embeddings (the frozen values are rebuilt, never stale).
#include "catch_torch.h"

#include <torch/types.h>

#include "avatar/avatar.h"
#include "avatar/frozen_decoders.h"
#include "small_avatar.h"

namespace {

// Largest absolute difference between two sets of offsets, and the largest offset magnitude.
std::pair<double, double> offset_difference(const handscs::DecodedOffsets& a,
                                            const handscs::DecodedOffsets& b) {
  double diff = 0, size = 0;
  const std::vector<std::pair<torch::Tensor, torch::Tensor>> pairs = {
      {a.dx, b.dx}, {a.dsigma, b.dsigma}, {a.dc, b.dc},
      {a.dx_f, b.dx_f}, {a.dsigma_f, b.dsigma_f}, {a.dc_f, b.dc_f}};
  for (const auto& [x, y] : pairs) {
    diff = std::max(diff, (x - y).abs().max().item<double>());
    size = std::max(size, x.abs().max().item<double>());
  }
  return {diff, size};
}

handscs::DecodedOffsets exact(handscs::OffsetDecodersImpl& d, const torch::Tensor& p,
                              const torch::Tensor& eg, const torch::Tensor& ea,
                              const torch::Tensor& t) {
  torch::AutoGradMode grad(true);
  return d.forward(p, eg, ea, t);
}

void open_gates(handscs::OffsetDecodersImpl& d, double value) {
  torch::NoGradGuard no_grad;
  for (auto& p : d.parameters())
    if (p.numel() == 1) p.fill_(value);
}

}  // namespace

TEST_CASE("frozen decoders: equal the decoders in double, with and without embeddings and SCS") {
  torch::manual_seed(3);
  const int64_t n = 50;
  for (const auto& [descriptor_dim, embedding_dim] :
       std::vector<std::pair<int64_t, int64_t>>{{20, 8}, {0, 8}, {20, 0}}) {
    INFO("|P| = " << descriptor_dim << ", d = " << embedding_dim);
    handscs::OffsetDecoders decoders(descriptor_dim, embedding_dim, 16, /*bf16=*/false);
    decoders->to(torch::kFloat64);
    open_gates(*decoders, 0.7);
    const auto opts = torch::TensorOptions().dtype(torch::kFloat64);
    const auto p = torch::randn({n, descriptor_dim}, opts);
    const auto eg = torch::randn({n, embedding_dim}, opts);
    const auto ea = torch::randn({n, embedding_dim}, opts);
    const auto t = torch::randn({n, 12}, opts);
    const handscs::FrozenDecoders frozen(*decoders, eg, ea);
    const auto [diff, size] = offset_difference(frozen.forward(p, t), exact(*decoders, p, eg, ea, t));
    CHECK(size > 0.01);  // the gates are open: the outputs are not trivially zero
    CHECK(diff < 1e-12);
  }
}

TEST_CASE("frozen decoders: the bf16 path stays within bf16 rounding of the float decoders") {
  torch::manual_seed(4);
  const int64_t n = 300;
  handscs::OffsetDecoders decoders(40, 32, 256, /*bf16=*/true);
  open_gates(*decoders, 0.5);
  const auto p = torch::randn({n, 40}), eg = torch::randn({n, 32}) * 0.1,
             ea = torch::randn({n, 32}) * 0.1, t = torch::randn({n, 12});
  const handscs::FrozenDecoders frozen(*decoders, eg, ea);
  // The reference: the same weights in float, no bf16 anywhere.
  handscs::OffsetDecoders reference(40, 32, 256, /*bf16=*/false);
  {
    torch::NoGradGuard no_grad;
    auto dst = reference->parameters();
    auto src = decoders->parameters();
    for (size_t k = 0; k < dst.size(); ++k) dst[k].copy_(src[k]);
  }
  const auto truth = exact(*reference, p, eg, ea, t);
  const auto [frozen_diff, size] = offset_difference(frozen.forward(p, t), truth);
  const auto [bf16_diff, unused] = offset_difference(exact(*decoders, p, eg, ea, t), truth);
  INFO("largest offset " << size << ", frozen bf16 error " << frozen_diff << ", training bf16 error "
                         << bf16_diff);
  CHECK(size > 0.05);
  // bf16 keeps 8 bits of mantissa (relative 2^-8 per rounding); through three layers the error
  // stays a few per cent of the largest offset, as the training path's own bf16 error does.
  CHECK(frozen_diff < 0.03 * size);
  CHECK(frozen_diff < 2 * bf16_diff);
}

TEST_CASE("frozen decoders: an avatar posed without autograd follows every weight update") {
  auto avatar = handscs_test::small_double_avatar();
  const auto pose = torch::randn({48}, torch::kFloat64) * 0.2;
  const auto shape = torch::zeros({10}, torch::kFloat64), trans = torch::zeros({3}, torch::kFloat64);
  auto check_same = [&](const char* when) {
    INFO(when);
    handscs::AvatarState with_grad, inference;
    {
      torch::AutoGradMode grad(true);
      with_grad = avatar.pose(pose, shape, trans);
    }
    {
      c10::InferenceMode guard;
      inference = avatar.pose(pose, shape, trans);
    }
    CHECK(torch::allclose(inference.posed.means, with_grad.posed.means.detach(), 0, 1e-12));
    CHECK(torch::allclose(inference.posed.covariances, with_grad.posed.covariances.detach(), 0, 1e-12));
    CHECK(torch::allclose(inference.posed.colors, with_grad.posed.colors.detach(), 0, 1e-12));
    return with_grad.posed.means.detach().clone();
  };
  const auto before = check_same("as built");
  {
    torch::NoGradGuard no_grad;  // an optimiser step: in place, as Adam does
    for (auto& p : avatar.decoders()->parameters()) p.add_(torch::randn_like(p) * 0.05);
  }
  const auto after_update = check_same("after an in-place update of the decoders");
  CHECK_FALSE(torch::allclose(before, after_update, 0, 1e-9));  // the update changed the render
  {
    torch::NoGradGuard no_grad;  // embeddings updated in place
    avatar.gaussians().embed_geometry.add_(0.05);
  }
  check_same("after an in-place update of the embeddings");
  auto& g = avatar.gaussians();  // densification: the embeddings replaced by larger tensors
  g.append(g.select(torch::arange(10, torch::kInt64)));
  check_same("after Gaussians were appended");
}
