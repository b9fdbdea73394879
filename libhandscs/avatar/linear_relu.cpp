#include "avatar/linear_relu.h"

#include <immintrin.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <utility>
#include <vector>

#include <ATen/Parallel.h>
#include <c10/util/BFloat16.h>
#include <torch/autograd.h>

#include "core/simd_level.h"

namespace handscs {

namespace linear_relu_detail {
namespace {

// Rows per block of the backward's bias sums: each block sums its rows in order and the blocks are
// added in order, so the bias gradient does not depend on the thread count. 256 rows of a 256-wide
// layer are 128 KiB per tensor (y, the gradient, the masked gradient), which stay in L2 while the
// block's columns are walked, and 10k rows give 40 blocks to share between the threads.
constexpr int64_t kRowBlock = 256;
// Rows per task of the forward pass at least: 64 rows of a 256-wide layer are 32 KiB, more work
// than a task's start costs.
constexpr int64_t kForwardGrain = 64;
constexpr uint16_t kBf16Nan = 0x7FC0;  // the quiet NaN c10::BFloat16's conversion writes

// c10's conversions (LibTorch's own): bits to float, and float to bits rounded to nearest even with
// NaN as kBf16Nan.
inline float from_bf16(uint16_t h) { return c10::detail::f32_from_bits(h); }
inline uint16_t to_bf16(float f) { return c10::detail::round_to_nearest_even(f); }

inline float relu_keep_nan(float v) { return v > 0.0f || std::isnan(v) ? v : 0.0f; }

// Where the AVX-512 kernels' unpacks put column c (0-31) of a 32-column group: the 128-bit lanes'
// words 0-3 in the first 16 floats, their words 4-7 in the next 16 (see unpack_bf16x32).
inline int unpacked_position(int c) { return (c % 8 < 4 ? 0 : 16) + (c / 8) * 4 + c % 4; }

// The forward pass over rows [r0, r1) of y [N, m]: bias per column (col_bias [m], and the same in
// unpacked_position's order per 32 columns for the AVX-512 kernel) or per entry (entry_bias [N, m]).
struct ForwardArgs {
  uint16_t* y;
  int64_t m;
  const float* col_bias;           // [m] or null
  const float* col_bias_unpacked;  // [m / 32 * 32] or null
  const uint16_t* entry_bias;      // [N, m] or null when col_bias is set
};

// The backward pass over rows [r0, r1): v_z = v_y where !(y <= 0), else 0; bias_sum [m] += v_z's
// rows. y is the forward's output: its NaNs are kBf16Nan (positive).
struct BackwardArgs {
  const uint16_t* v_y;  // [N, m]
  const uint16_t* y;    // [N, m]
  uint16_t* v_z;        // [N, m]
  int64_t m;
};

void forward_generic(const ForwardArgs& a, int64_t r0, int64_t r1, int64_t j0 = 0) {
  for (int64_t r = r0; r < r1; ++r)
    for (int64_t j = j0; j < a.m; ++j) {
      const int64_t i = r * a.m + j;
      const float bias = a.col_bias ? a.col_bias[j] : from_bf16(a.entry_bias[i]);
      a.y[i] = to_bf16(relu_keep_nan(from_bf16(a.y[i]) + bias));
    }
}

void backward_generic(const BackwardArgs& a, int64_t r0, int64_t r1, float* bias_sum, int64_t j0 = 0) {
  for (int64_t r = r0; r < r1; ++r)
    for (int64_t j = j0; j < a.m; ++j) {
      const int64_t i = r * a.m + j;
      const uint16_t v_z = from_bf16(a.y[i]) <= 0.0f ? 0 : a.v_y[i];
      a.v_z[i] = v_z;
      bias_sum[j] += from_bf16(v_z);
    }
}

#pragma GCC push_options
#pragma GCC target("avx512f,avx512bw")
// GCC 12 warns inside its own intrinsics here (their unmasked forms read an "undefined" register:
// GCC bug 105593), not about this code.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"

// 32 bf16 values as two float registers (a bf16 value over 16 zero bits is its float), in the order
// of the 128-bit lanes' unpacks: words 0-3 of each lane in `low`, words 4-7 in `high`.
inline void unpack_bf16x32(__m512i raw, __m512& low, __m512& high) {
  const __m512i zero = _mm512_setzero_si512();
  low = _mm512_castsi512_ps(_mm512_unpacklo_epi16(zero, raw));
  high = _mm512_castsi512_ps(_mm512_unpackhi_epi16(zero, raw));
}

// Floats rounded as to_bf16, each result in its 32-bit lane's low 16 bits.
inline __m512i round_to_bf16_bits(__m512 v) {
  const __m512i bits = _mm512_castps_si512(v);
  const __m512i lsb = _mm512_and_si512(_mm512_srli_epi32(bits, 16), _mm512_set1_epi32(1));
  const __m512i rounded =
      _mm512_srli_epi32(_mm512_add_epi32(bits, _mm512_add_epi32(lsb, _mm512_set1_epi32(0x7FFF))), 16);
  return _mm512_mask_mov_epi32(rounded, _mm512_cmp_ps_mask(v, v, _CMP_UNORD_Q), _mm512_set1_epi32(kBf16Nan));
}

// Kept where v > 0 or NaN (unordered), else +0: relu_keep_nan on 16 floats.
inline __m512 relu_keep_nan16(__m512 v) {
  return _mm512_maskz_mov_ps(_mm512_cmp_ps_mask(v, _mm512_setzero_ps(), _CMP_NLE_UQ), v);
}

void forward_avx512(const ForwardArgs& a, int64_t r0, int64_t r1) {
  const int64_t vector_end = a.m / 32 * 32;
  for (int64_t r = r0; r < r1; ++r) {
    uint16_t* row = a.y + r * a.m;
    for (int64_t j = 0; j < vector_end; j += 32) {
      __m512 low, high, bias_low, bias_high;
      unpack_bf16x32(_mm512_loadu_si512(row + j), low, high);
      if (a.col_bias) {
        bias_low = _mm512_loadu_ps(a.col_bias_unpacked + j);
        bias_high = _mm512_loadu_ps(a.col_bias_unpacked + j + 16);
      } else {
        unpack_bf16x32(_mm512_loadu_si512(a.entry_bias + r * a.m + j), bias_low, bias_high);
      }
      low = relu_keep_nan16(_mm512_add_ps(low, bias_low));
      high = relu_keep_nan16(_mm512_add_ps(high, bias_high));
      // The 32-bit lanes' low halves back to 16-bit words, in the columns' order (values <= 0xFFFF,
      // so the unsigned saturation never acts).
      _mm512_storeu_si512(row + j, _mm512_packus_epi32(round_to_bf16_bits(low), round_to_bf16_bits(high)));
    }
  }
  if (vector_end < a.m) forward_generic(a, r0, r1, vector_end);
}

void backward_avx512(const BackwardArgs& a, int64_t r0, int64_t r1, float* bias_sum) {
  // 32 bf16 values per register, kept as 16-bit lanes: the mask and the selection need no widening.
  const int64_t vector_end = a.m / 32 * 32;
  const __m512i zero = _mm512_setzero_si512();
  alignas(64) float sums[32];
  // Columns outer, rows inner: each column's sum stays in a register over the block's rows.
  for (int64_t j = 0; j < vector_end; j += 32) {
    __m512 sum_low = _mm512_setzero_ps(), sum_high = _mm512_setzero_ps();
    for (int64_t r = r0; r < r1; ++r) {
      const int64_t i = r * a.m + j;
      const __m512i y = _mm512_loadu_si512(a.y + i);
      // !(y <= 0) for the forward's outputs (>= +0, NaN only as kBf16Nan): positive as a signed
      // 16-bit integer.
      const __mmask32 pass = _mm512_cmpgt_epi16_mask(y, zero);
      // A plain load, then the mask: a masked load was several times slower on Zen 4 (measured).
      const __m512i v_z = _mm512_maskz_mov_epi16(pass, _mm512_loadu_si512(a.v_y + i));
      _mm512_storeu_si512(a.v_z + i, v_z);
      __m512 low, high;
      unpack_bf16x32(v_z, low, high);
      sum_low = _mm512_add_ps(sum_low, low);
      sum_high = _mm512_add_ps(sum_high, high);
    }
    _mm512_store_ps(sums, sum_low);
    _mm512_store_ps(sums + 16, sum_high);
    for (int c = 0; c < 32; ++c) bias_sum[j + c] += sums[unpacked_position(c)];
  }
  if (vector_end < a.m) backward_generic(a, r0, r1, bias_sum, vector_end);
}

#pragma GCC diagnostic pop
#pragma GCC pop_options

// The AVX-512 kernels need AVX-512BW too (16-bit lanes); every CPU with native bf16 matmuls has it.
bool use_avx512() { return active_simd_level() == SimdLevel::avx512 && __builtin_cpu_supports("avx512bw"); }

uint16_t* bits_of(torch::Tensor& t) { return reinterpret_cast<uint16_t*>(t.data_ptr<at::BFloat16>()); }
const uint16_t* bits_of(const torch::Tensor& t) {
  return reinterpret_cast<const uint16_t*>(t.data_ptr<at::BFloat16>());
}

// v_z (the ReLU's mask applied to v_y, the gradient of its output y) and the bias gradient, float [m].
std::pair<torch::Tensor, torch::Tensor> relu_bias_bwd(const torch::Tensor& v_y, const torch::Tensor& y) {
  const int64_t n = y.size(0), m = y.size(1);
  auto v_z = torch::empty_like(y);
  const BackwardArgs args{bits_of(v_y), bits_of(y), bits_of(v_z), m};
  const int64_t blocks = (n + kRowBlock - 1) / kRowBlock;
  std::vector<float> partial(static_cast<size_t>(blocks * m), 0.0f);
  const bool avx512 = use_avx512();
  at::parallel_for(0, blocks, 1, [&](int64_t b0, int64_t b1) {
    for (int64_t b = b0; b < b1; ++b) {
      const int64_t r0 = b * kRowBlock, r1 = std::min(n, r0 + kRowBlock);
      float* sum = partial.data() + b * m;
      avx512 ? backward_avx512(args, r0, r1, sum) : backward_generic(args, r0, r1, sum);
    }
  });
  auto v_bias = torch::zeros({m}, torch::kFloat);
  float* total = v_bias.data_ptr<float>();
  for (int64_t b = 0; b < blocks; ++b)
    for (int64_t j = 0; j < m; ++j) total[j] += partial[b * m + j];
  return {v_z, v_bias};
}

using torch::autograd::AutogradContext;
using torch::autograd::variable_list;

// Once differentiable: the backward's pass is not itself recorded.
struct LinearReluFunction : public torch::autograd::Function<LinearReluFunction> {
  enum Slot { kX, kWeight, kBias, kNumSlots };  // inputs, and their gradients' places
  enum Saved { kSavedX, kSavedWeight, kSavedY };

  static torch::Tensor forward(AutogradContext* ctx, const torch::Tensor& x, const torch::Tensor& weight,
                               const torch::Tensor& bias) {
    auto y = torch::mm(x, weight.t());
    add_bias_relu_(y, bias.contiguous());
    ctx->save_for_backward({x, weight, y});
    return y;
  }

  static variable_list backward(AutogradContext* ctx, variable_list grad_outputs) {
    variable_list grads(kNumSlots);
    if (!grad_outputs[0].defined()) return grads;
    const auto saved = ctx->get_saved_variables();
    const auto v_y = grad_outputs[0].to(torch::kBFloat16).contiguous();
    const auto [v_z, v_bias] = relu_bias_bwd(v_y, saved[kSavedY]);
    if (ctx->needs_input_grad(kX)) grads[kX] = torch::mm(v_z, saved[kSavedWeight]);
    if (ctx->needs_input_grad(kWeight)) grads[kWeight] = torch::mm(v_z.t(), saved[kSavedX]);
    if (ctx->needs_input_grad(kBias)) grads[kBias] = v_bias;
    return grads;
  }
};

}  // namespace
}  // namespace linear_relu_detail

void add_bias_relu_(torch::Tensor& y, const torch::Tensor& bias) {
  using namespace linear_relu_detail;
  TORCH_CHECK(y.dim() == 2 && y.scalar_type() == torch::kBFloat16 && y.is_contiguous() && y.is_cpu(),
              "add_bias_relu_: y must be a contiguous CPU bf16 [N, M] tensor, got ", y.scalar_type(), " ",
              y.sizes());
  TORCH_CHECK(!(torch::GradMode::is_enabled() && y.requires_grad()),
              "add_bias_relu_: y requires grad; this in-place pass is not recorded (use linear_relu)");
  TORCH_CHECK(bias.is_cpu(), "add_bias_relu_: bias must be a CPU tensor");
  const int64_t n = y.size(0), m = y.size(1);
  const bool per_column = bias.dim() == 1;
  if (per_column) {
    TORCH_CHECK(bias.scalar_type() == torch::kFloat && bias.size(0) == m && bias.is_contiguous(),
                "add_bias_relu_: a per-column bias must be contiguous float [", m, "], got ",
                bias.scalar_type(), " ", bias.sizes());
  } else {
    TORCH_CHECK(bias.scalar_type() == torch::kBFloat16 && bias.sizes() == y.sizes() && bias.is_contiguous(),
                "add_bias_relu_: a per-entry bias must be contiguous bf16 ", y.sizes(), ", got ",
                bias.scalar_type(), " ", bias.sizes());
  }
  const bool avx512 = use_avx512();
  std::vector<float> unpacked;  // the per-column bias in the AVX-512 kernel's order
  if (per_column && avx512) {
    const float* col = bias.data_ptr<float>();
    unpacked.resize(static_cast<size_t>(m / 32 * 32));
    for (int64_t j = 0; j + 32 <= m; j += 32)
      for (int c = 0; c < 32; ++c) unpacked[j + unpacked_position(c)] = col[j + c];
  }
  const ForwardArgs args{bits_of(y), m, per_column ? bias.data_ptr<float>() : nullptr,
                         per_column ? unpacked.data() : nullptr, per_column ? nullptr : bits_of(bias)};
  // Each row is independent: any split over threads gives the same bits.
  at::parallel_for(0, n, kForwardGrain, [&](int64_t r0, int64_t r1) {
    avx512 ? forward_avx512(args, r0, r1) : forward_generic(args, r0, r1);
  });
}

torch::Tensor linear_relu(const torch::Tensor& x, const torch::Tensor& weight, const torch::Tensor& bias) {
  TORCH_CHECK(x.dim() == 2 && weight.dim() == 2 && x.size(1) == weight.size(1),
              "linear_relu: x [N, K] and weight [M, K] expected, got ", x.sizes(), " and ", weight.sizes());
  TORCH_CHECK(x.scalar_type() == torch::kBFloat16 && weight.scalar_type() == torch::kBFloat16,
              "linear_relu: x and weight must be bf16, got ", x.scalar_type(), " and ", weight.scalar_type());
  TORCH_CHECK(bias.dim() == 1 && bias.size(0) == weight.size(0) && bias.scalar_type() == torch::kFloat,
              "linear_relu: bias must be float [", weight.size(0), "], got ", bias.scalar_type(), " ",
              bias.sizes());
  const bool graph = torch::GradMode::is_enabled() &&
                     (x.requires_grad() || weight.requires_grad() || bias.requires_grad());
  if (graph) return linear_relu_detail::LinearReluFunction::apply(x, weight, bias);
  auto y = torch::mm(x, weight.t());
  add_bias_relu_(y, bias.contiguous());
  return y;
}

}  // namespace handscs
