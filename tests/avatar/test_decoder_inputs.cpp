// avatar/decoder_inputs.h: the one-pass bf16 decoder inputs against the LibTorch form they replace
// (cat, then cast to bfloat16; autograd's casts, slices and sums backwards), bit for bit: values
// with rounding ties, NaN, inf and subnormals, gradients of every part with all, some or none of the
// decoder inputs used, empty parts, at both SIMD levels, and through the whole decoders.
#include "catch_torch.h"

#include <cmath>
#include <limits>

#include <torch/csrc/autograd/autograd.h>

#include "avatar/decoder_inputs.h"
#include "avatar/decoders.h"
#include "core/simd_level.h"
#include "tensor_bits.h"

namespace {

using handscs_test::same_bits;

struct Parts {
  torch::Tensor descriptor, e_g, e_a, transforms;  // float leaves
  std::vector<torch::Tensor> all() const { return {descriptor, e_g, e_a, transforms}; }
};

Parts random_parts(int64_t n, int64_t p, int64_t d) {
  const auto leaf = [](torch::Tensor t) { return t.requires_grad_(true); };
  Parts parts{torch::randn({n, p}), torch::randn({n, d}), torch::randn({n, d}), torch::randn({n, 12})};
  torch::NoGradGuard no_grad;
  if (n > 3 && p > 2) {
    // Ties (rounded to even both ways), NaN, inf and a subnormal in the inputs.
    parts.descriptor[0][0] = 1.0f + std::ldexp(1.0f, -8);
    parts.descriptor[0][1] = 1.0f + 3 * std::ldexp(1.0f, -8);
    parts.descriptor[1][0] = std::nan("");
    parts.descriptor[2][1] = -std::numeric_limits<float>::infinity();
    parts.descriptor[3][2] = std::numeric_limits<float>::denorm_min() * 5;
  }
  return {leaf(parts.descriptor), leaf(parts.e_g), leaf(parts.e_a), leaf(parts.transforms)};
}

std::vector<torch::Tensor> cat_and_cast(const Parts& p) {
  return {torch::cat({p.descriptor, p.e_g, p.transforms}, 1).to(torch::kBFloat16),
          torch::cat({p.descriptor, p.e_a, p.transforms}, 1).to(torch::kBFloat16),
          torch::cat({p.descriptor, p.e_g, p.e_a, p.transforms}, 1).to(torch::kBFloat16)};
}

std::vector<torch::Tensor> one_pass(const Parts& p) {
  const auto in = handscs::bf16_decoder_inputs(p.descriptor, p.e_g, p.e_a, p.transforms);
  return {in.geometry, in.appearance, in.fusion};
}

// Gradients of sum(output_k * cotangent_k) over the used outputs, for the parts.
std::vector<torch::Tensor> grads_of(const std::vector<torch::Tensor>& outputs, const std::vector<torch::Tensor>& cot,
                                    const std::vector<bool>& used, const Parts& p) {
  torch::Tensor loss;
  for (size_t k = 0; k < outputs.size(); ++k) {
    if (!used[k]) continue;
    const auto term = (outputs[k].to(torch::kFloat) * cot[k]).sum();
    loss = loss.defined() ? loss + term : term;
  }
  return torch::autograd::grad({loss}, p.all(), {}, false, false, true);
}

}  // namespace

TEST_CASE("decoder inputs: values and gradients are the cat-and-cast form's, bit for bit") {
  torch::manual_seed(9);
  for (const auto level : {handscs::SimdLevel::generic, handscs::SimdLevel::avx512}) {
    handscs::set_simd_level(level);
    INFO("level " << handscs::simd_level_name(handscs::active_simd_level()));
    // 700 rows: three parallel tasks; the default widths (|P| = 36, d = 32) and odd ones; empty parts.
    for (const auto& [n, p, d] : {std::tuple<int64_t, int64_t, int64_t>{700, 36, 32}, {37, 5, 3}, {9, 0, 4}, {6, 7, 0}}) {
      INFO("n " << n << ", |P| " << p << ", d " << d);
      const auto parts = random_parts(n, p, d);
      const auto mine = one_pass(parts), ref = cat_and_cast(parts);
      for (int k = 0; k < 3; ++k) CHECK(same_bits(mine[k], ref[k]));
      std::vector<torch::Tensor> cot;
      for (const auto& r : ref) cot.push_back(torch::randn(r.sizes()).to(torch::kBFloat16).to(torch::kFloat));
      if (p > 0) {
        // Sums of bf16 values are mostly exact in float, so the order of the three terms rarely
        // shows. Here it does: with terms {1, 2^-30, -1} the tiny one survives only when added
        // last, and rows 0-2 make each decoder's term the tiny one in turn (column 0 of the
        // descriptor is column 0 of every decoder input).
        const float terms[3][3] = {{std::ldexp(1.0f, -30), 1, -1}, {1, std::ldexp(1.0f, -30), -1},
                                   {1, -1, std::ldexp(1.0f, -30)}};
        for (int row = 0; row < 3; ++row)
          for (int k = 0; k < 3; ++k) cot[k][row][0] = terms[row][k];
      }
      // All used, one used, two used.
      for (const auto& used : {std::vector<bool>{true, true, true}, {false, true, false}, {true, false, true}}) {
        INFO("used " << used[0] << used[1] << used[2]);
        const auto g = grads_of(mine, cot, used, parts), g_ref = grads_of(ref, cot, used, parts);
        for (int part = 0; part < 4; ++part) {
          INFO("part " << part);
          REQUIRE(g[part].defined() == g_ref[part].defined());
          if (g[part].defined()) CHECK(same_bits(g[part], g_ref[part]));
        }
      }
    }
  }
  handscs::set_simd_level(handscs::detected_simd_level());
}

TEST_CASE("decoder inputs: a part with a consumer outside the decoders gets its gradient added as before") {
  // As the inter-pose loss uses the embeddings after the decoders have: its gradient and the
  // decoders' shares reach the embedding in one order, which the sum's rounding shows here with
  // terms {1, -1, 2^-30}: exact only if the tiny one comes last.
  torch::manual_seed(12);
  const int64_t n = 40, p = 6, d = 4;
  const auto parts = random_parts(n, p, d);
  const float tiny = std::ldexp(1.0f, -30);
  const auto run = [&](bool fused_op) {
    const auto inputs = fused_op ? one_pass(parts) : cat_and_cast(parts);
    const auto other = torch::cat({parts.e_g, parts.descriptor}, 1);  // built after the inputs
    std::vector<torch::Tensor> cot;
    for (const auto& in : inputs) cot.push_back(torch::zeros(in.sizes()));
    auto cot_other = torch::zeros(other.sizes());
    // Rows 0-2: the tiny term from the other consumer, from fusion, from geometry (e_g's column 0
    // is column p of geometry's and fusion's inputs).
    const float terms[3][3] = {{tiny, 1, -1}, {1, tiny, -1}, {1, -1, tiny}};  // other, fusion, geometry
    for (int row = 0; row < 3; ++row) {
      cot_other[row][0] = terms[row][0];
      cot[2][row][p] = terms[row][1];
      cot[0][row][p] = terms[row][2];
    }
    auto loss = (other * cot_other).sum();
    for (int k = 0; k < 3; ++k) loss = loss + (inputs[k].to(torch::kFloat) * cot[k]).sum();
    return torch::autograd::grad({loss}, parts.all());
  };
  const auto mine = run(true), ref = run(false);
  for (int part = 0; part < 4; ++part) {
    INFO("part " << part);
    CHECK(same_bits(mine[part], ref[part]));
  }
  // The order shows: one of the three rows keeps the tiny term.
  CHECK((ref[1].select(1, 0).slice(0, 0, 3) != 0).any().item<bool>());
}

TEST_CASE("decoder inputs: the bf16 decoders give the outputs and gradients of their float-input form") {
  torch::manual_seed(10);
  const int64_t n = 300, p = 36, d = 32;
  handscs::OffsetDecoders decoders(p, d, 64, /*bf16=*/true);
  {
    torch::NoGradGuard no_grad;
    for (auto& param : decoders->parameters())
      if (param.numel() == 1) param.fill_(0.3);  // open gates
  }
  const auto parts = random_parts(n, p, d);
  {
    torch::NoGradGuard no_grad;
    parts.descriptor[1][0] = 0.5;  // no NaN here: it would make every gradient NaN
    parts.descriptor[2][1] = -1.0;
  }
  const auto mine = decoders->outputs(parts.descriptor, parts.e_g, parts.e_a, parts.transforms);
  // The form before: each GatedMlp on its float concatenation (cast inside the MLP).
  const auto geometry = decoders->geometry->forward(torch::cat({parts.descriptor, parts.e_g, parts.transforms}, 1));
  const auto appearance = decoders->appearance->forward(torch::cat({parts.descriptor, parts.e_a, parts.transforms}, 1));
  const auto fusion =
      decoders->fusion->forward(torch::cat({parts.descriptor, parts.e_g, parts.e_a, parts.transforms}, 1));
  CHECK(same_bits(mine.geometry, geometry));
  CHECK(same_bits(mine.appearance, appearance));
  CHECK(same_bits(mine.fusion, fusion));
  const auto loss = [&](const torch::Tensor& g, const torch::Tensor& a, const torch::Tensor& f) {
    torch::manual_seed(11);
    return (g * torch::randn_like(g)).sum() + (a * torch::randn_like(a)).sum() + (f * torch::randn_like(f)).sum();
  };
  auto inputs = parts.all();
  for (const auto& param : decoders->parameters()) inputs.push_back(param);
  const auto g = torch::autograd::grad({loss(mine.geometry, mine.appearance, mine.fusion)}, inputs);
  const auto g_ref = torch::autograd::grad({loss(geometry, appearance, fusion)}, inputs);
  for (size_t k = 0; k < g.size(); ++k) {
    INFO("input " << k);
    CHECK(same_bits(g[k], g_ref[k]));
  }
}

TEST_CASE("decoder inputs: strided parts and zero rows") {
  torch::manual_seed(13);
  // Parts that are column slices of wider tensors (as the culled or sliced tensors of callers may be).
  const auto wide = torch::randn({50, 20});
  const auto d = wide.slice(1, 0, 6), e_g = wide.slice(1, 6, 10), e_a = wide.slice(1, 10, 14);
  const auto t = torch::randn({12, 50}).t();
  const Parts strided{d, e_g, e_a, t};
  const auto mine = one_pass(strided), ref = cat_and_cast(strided);
  for (int k = 0; k < 3; ++k) CHECK(same_bits(mine[k], ref[k]));
  const auto empty = random_parts(0, 5, 3);
  const auto none = one_pass(empty);
  CHECK(none[2].sizes() == torch::IntArrayRef({0, 5 + 3 + 3 + 12}));
  const auto g = torch::autograd::grad({none[2].to(torch::kFloat).sum()}, empty.all(), {}, false, false, true);
  CHECK(g[0].sizes() == torch::IntArrayRef({0, 5}));
}

TEST_CASE("decoder inputs: wrong shapes and dtypes are refused with their sizes") {
  const auto f = [](std::vector<int64_t> s) { return torch::zeros(s); };
  CHECK_THROWS_WITH(handscs::bf16_decoder_inputs(f({4, 3}), f({3, 2}), f({4, 2}), f({4, 12})),
                    Catch::Contains("embed_geometry must be [4, columns], got [3, 2]"));
  CHECK_THROWS_WITH(handscs::bf16_decoder_inputs(f({4, 3}), f({4, 2}), f({4, 2}).to(torch::kDouble), f({4, 12})),
                    Catch::Contains("embed_appearance must be a float CPU tensor"));
  CHECK_THROWS_WITH(handscs::bf16_decoder_inputs(f({4, 3}), f({4, 2}), f({4, 5}), f({4, 12})),
                    Catch::Contains("one width"));
  CHECK_THROWS_WITH(handscs::bf16_decoder_inputs(f({4, 3}), f({4, 2}), f({4, 2}), f({4, 9})),
                    Catch::Contains("transforms must be [N, 12], got [4, 9]"));
}
