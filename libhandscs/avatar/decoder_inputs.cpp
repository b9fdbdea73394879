#include "avatar/decoder_inputs.h"

#include <algorithm>
#include <array>
#include <cstdint>
#include <cstring>
#include <vector>

#include <ATen/Parallel.h>
#include <c10/util/BFloat16.h>
#include <torch/csrc/autograd/custom_function.h>

#include "core/lanes.h"

namespace handscs {

namespace decoder_inputs_detail {
namespace {

enum Part { kDescriptor, kEmbedGeometry, kEmbedAppearance, kTransforms, kParts };
enum Decoder { kGeometry, kAppearance, kFusion, kDecoders };
// Which parts each decoder's input holds, in column order.
constexpr bool kHolds[kDecoders][kParts] = {{true, true, false, true}, {true, false, true, true}, {true, true, true, true}};
// The op's inputs: each part once per decoder input that holds it (10 slots), so that its backward
// returns each decoder's share of a part's gradient separately and autograd adds the shares, and
// any other consumer's gradient, in the order it did for the three cats: fusion's first (autograd
// runs the last-built node first), then appearance's, then geometry's (tested bit for bit).
constexpr int kSlots = 10;
constexpr Decoder kSlotDecoder[kSlots] = {kFusion,     kFusion,     kFusion,    kFusion,    kAppearance,
                                          kAppearance, kAppearance, kGeometry,  kGeometry,  kGeometry};
constexpr Part kSlotPart[kSlots] = {kDescriptor, kEmbedGeometry,   kEmbedAppearance, kTransforms,    kDescriptor,
                                    kEmbedAppearance, kTransforms, kDescriptor,      kEmbedGeometry, kTransforms};

// Every slot names a part its decoder holds, and every held part has a slot.
constexpr bool slots_match_holds() {
  int held = 0;
  for (int k = 0; k < kDecoders; ++k)
    for (int part = 0; part < kParts; ++part) held += kHolds[k][part];
  for (int slot = 0; slot < kSlots; ++slot)
    if (!kHolds[kSlotDecoder[slot]][kSlotPart[slot]]) return false;
  return held == kSlots;
}
static_assert(slots_match_holds(), "decoder input slots and kHolds disagree");
constexpr int64_t kRowsPerTask = 256;  // ~0.2 MB of output per task: more work than a task's start

template <class T>
using PartPointers = std::array<T*, kParts>;
template <class T>
using DecoderPointers = std::array<T*, kDecoders>;
template <class T>
using SlotPointers = std::array<T*, kSlots>;

struct InputLayout {
  int64_t width[kParts];               // columns of each part
  int64_t offset[kDecoders][kParts];   // where a part starts in a decoder's row; -1: not there
  int64_t row_width[kDecoders];        // I_k
  explicit InputLayout(const std::array<int64_t, kParts>& widths) {
    for (int k = 0; k < kDecoders; ++k) {
      row_width[k] = 0;
      for (int part = 0; part < kParts; ++part) {
        width[part] = widths[part];
        offset[k][part] = kHolds[k][part] ? row_width[k] : -1;
        if (kHolds[k][part]) row_width[k] += widths[part];
      }
    }
  }
};

#define HANDSCS_KERNELS "avatar/decoder_inputs_rows.inc"
#include "core/generic_and_avx512.inc"

using torch::autograd::AutogradContext;
using torch::autograd::variable_list;

struct DecoderInputsFunction : public torch::autograd::Function<DecoderInputsFunction> {
  // slots: the parts in kSlotPart's order (the same four tensors repeated).
  static variable_list forward(AutogradContext* ctx, at::TensorList slots) {
    ctx->set_materialize_grads(false);  // an unused decoder input's gradient stays undefined (none)
    std::array<torch::Tensor, kParts> parts;
    for (int slot = 0; slot < kSlots; ++slot)
      if (!parts[kSlotPart[slot]].defined()) parts[kSlotPart[slot]] = slots[slot].contiguous();
    std::array<int64_t, kParts> widths{};
    for (int part = 0; part < kParts; ++part) widths[part] = parts[part].size(1);
    ctx->saved_data["widths"] = std::vector<int64_t>(widths.begin(), widths.end());
    const InputLayout layout(widths);
    const int64_t n = parts[0].size(0);
    variable_list rows;
    DecoderPointers<uint16_t> row_ptrs{};
    for (int k = 0; k < kDecoders; ++k) {
      rows.push_back(torch::empty({n, layout.row_width[k]}, parts[0].options().dtype(torch::kBFloat16)));
      row_ptrs[k] = reinterpret_cast<uint16_t*>(rows[k].data_ptr<at::BFloat16>());
    }
    PartPointers<const float> part_ptrs{};
    for (int part = 0; part < kParts; ++part) part_ptrs[part] = parts[part].data_ptr<float>();
    const bool simd = lanes16_active<float>();
    at::parallel_for(0, n, kRowsPerTask, [&](int64_t r0, int64_t r1) {
      if (simd) return avx512::write_rows(layout, part_ptrs, row_ptrs, r0, r1);
      generic::write_rows(layout, part_ptrs, row_ptrs, r0, r1);
    });
    return rows;
  }

  static variable_list backward(AutogradContext* ctx, variable_list grads) {
    const auto widths_saved = ctx->saved_data["widths"].toIntVector();
    std::array<int64_t, kParts> widths{};
    std::copy(widths_saved.begin(), widths_saved.end(), widths.begin());
    const InputLayout layout(widths);
    DecoderPointers<const uint16_t> grad_ptrs{};
    variable_list kept(kDecoders);  // contiguous bf16 gradients (undefined: none)
    int64_t n = 0;
    for (int k = 0; k < kDecoders; ++k) {
      if (!grads[k].defined()) continue;
      kept[k] = grads[k].to(torch::kBFloat16).contiguous();
      grad_ptrs[k] = reinterpret_cast<const uint16_t*>(kept[k].data_ptr<at::BFloat16>());
      n = kept[k].size(0);
    }
    variable_list out(kSlots);
    SlotPointers<float> out_ptrs{};
    for (int slot = 0; slot < kSlots; ++slot) {
      // None where autograd has none: the slot is not asked for or its decoder input is unused.
      if (!ctx->needs_input_grad(slot) || !kept[kSlotDecoder[slot]].defined()) continue;
      out[slot] = torch::empty({n, widths[kSlotPart[slot]]}, torch::TensorOptions().dtype(torch::kFloat));
      out_ptrs[slot] = out[slot].data_ptr<float>();
    }
    const bool simd = lanes16_active<float>();
    at::parallel_for(0, n, kRowsPerTask, [&](int64_t r0, int64_t r1) {
      if (simd) return avx512::gradient_rows(layout, grad_ptrs, out_ptrs, r0, r1);
      generic::gradient_rows(layout, grad_ptrs, out_ptrs, r0, r1);
    });
    return out;
  }
};

}  // namespace
}  // namespace decoder_inputs_detail

Bf16DecoderInputs bf16_decoder_inputs(const torch::Tensor& descriptor, const torch::Tensor& embed_geometry,
                                      const torch::Tensor& embed_appearance, const torch::Tensor& transforms) {
  const torch::Tensor parts[] = {descriptor, embed_geometry, embed_appearance, transforms};
  const char* names[] = {"descriptor", "embed_geometry", "embed_appearance", "transforms"};
  for (int part = 0; part < 4; ++part) {
    TORCH_CHECK(parts[part].dim() == 2 && parts[part].size(0) == descriptor.size(0),
                "bf16_decoder_inputs: ", names[part], " must be [", descriptor.size(0), ", columns], got ",
                parts[part].sizes());
    TORCH_CHECK(parts[part].scalar_type() == torch::kFloat && parts[part].is_cpu(), "bf16_decoder_inputs: ",
                names[part], " must be a float CPU tensor, got ", parts[part].scalar_type(), " on ",
                parts[part].device());
  }
  TORCH_CHECK(transforms.size(1) == 12, "bf16_decoder_inputs: transforms must be [N, 12], got ", transforms.sizes());
  TORCH_CHECK(embed_geometry.size(1) == embed_appearance.size(1),
              "bf16_decoder_inputs: the embeddings must have one width, got ", embed_geometry.size(1), " and ",
              embed_appearance.size(1));
  using decoder_inputs_detail::kSlotPart;
  std::vector<torch::Tensor> slots;
  for (const auto part : kSlotPart) slots.push_back(parts[part]);
  const auto rows = decoder_inputs_detail::DecoderInputsFunction::apply(at::TensorList(slots));
  return {rows[0], rows[1], rows[2]};
}

}  // namespace handscs
