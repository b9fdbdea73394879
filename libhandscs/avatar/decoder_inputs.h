// The three decoders' inputs in bfloat16, built in one pass: geometry [P, e_g, vec(T)],
// appearance [P, e_a, vec(T)], fusion [P, e_g, e_a, vec(T)] (avatar/decoders.h), in place of the
// LibTorch form: three cats and three casts, and in the backward three casts and the slices. Values
// and gradients are that form's bit for bit: the same rounding (c10's round to nearest even; NaN as
// 0x7FC0), and each decoder's share of a shared part's gradient handed to autograd separately, in
// the order the cats' backwards handed them, so that autograd adds the shares (and any other
// consumer's gradient, e.g. the inter-pose loss's of the embeddings) as it did
// (tests/avatar/test_decoder_inputs.cpp).
#pragma once

#include <torch/types.h>

namespace handscs {

struct Bf16DecoderInputs {
  torch::Tensor geometry, appearance, fusion;  // [N, I_k] bfloat16, contiguous
};

// descriptor [N, |P|] (|P| may be 0), embed_geometry, embed_appearance [N, d] (d may be 0),
// transforms [N, 12]: float. Differentiable in each input that requires grad (once: no double
// backward).
Bf16DecoderInputs bf16_decoder_inputs(const torch::Tensor& descriptor, const torch::Tensor& embed_geometry,
                                      const torch::Tensor& embed_appearance, const torch::Tensor& transforms);

}  // namespace handscs
