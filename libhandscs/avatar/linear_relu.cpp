#include "avatar/linear_relu.h"

#include <immintrin.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <vector>

#include <ATen/Parallel.h>
#include <torch/autograd.h>

#include "core/simd_level.h"

namespace handscs {

namespace linear_relu_detail {

// Rows per block of the backward's bias sums: each block sums its rows in order and the blocks are
// added in order, so the bias gradient does not depend on the thread count.
constexpr int64_t kRowBlock = 256;
constexpr uint16_t kBf16Nan = 0x7FC0;  // the quiet NaN LibTorch's float -> bf16 writes

inline float from_bf16(uint16_t h) {
  const uint32_t bits = uint32_t(h) << 16;
  float f;
  std::memcpy(&f, &bits, sizeof f);
  return f;
}

// Round to nearest even, NaN to kBf16Nan: c10::BFloat16's conversion.
inline uint16_t to_bf16(float f) {
  if (std::isnan(f)) return kBf16Nan;
  uint32_t bits;
  std::memcpy(&bits, &f, sizeof bits);
  return static_cast<uint16_t>((bits + 0x7FFFu + ((bits >> 16) & 1u)) >> 16);
}

inline float relu_keep_nan(float v) { return v > 0.0f || std::isnan(v) ? v : 0.0f; }

// The forward pass over rows [r0, r1) of y [N, m]: bias per column (col_bias [m]) or per entry
// (entry_bias [N, m]); exactly one is non-null.
struct ForwardArgs {
  uint16_t* y;
  int64_t m;
  const float* col_bias;
  const uint16_t* entry_bias;
};

// The backward pass over rows [r0, r1): gz = g where !(y <= 0), else 0; bias_sum [m] += gz's rows.
struct BackwardArgs {
  const uint16_t* g;
  const uint16_t* y;
  uint16_t* gz;
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
      const uint16_t g = from_bf16(a.y[i]) <= 0.0f ? 0 : a.g[i];
      a.gz[i] = g;
      bias_sum[j] += from_bf16(g);
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

// Where unpack_bf16x32 puts column c (0-31) of a 32-column group.
inline int unpacked_position(int c) { return (c % 8 < 4 ? 0 : 16) + (c / 8) * 4 + c % 4; }

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
  std::vector<float> col_bias;  // the per-column bias in the unpacks' order
  if (a.col_bias) {
    col_bias.resize(static_cast<size_t>(vector_end));
    for (int64_t j = 0; j < vector_end; j += 32)
      for (int c = 0; c < 32; ++c) col_bias[j + unpacked_position(c)] = a.col_bias[j + c];
  }
  for (int64_t r = r0; r < r1; ++r) {
    uint16_t* row = a.y + r * a.m;
    for (int64_t j = 0; j < vector_end; j += 32) {
      __m512 low, high, bias_low, bias_high;
      unpack_bf16x32(_mm512_loadu_si512(row + j), low, high);
      if (a.col_bias) {
        bias_low = _mm512_loadu_ps(col_bias.data() + j);
        bias_high = _mm512_loadu_ps(col_bias.data() + j + 16);
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
  const __m512i abs_mask = _mm512_set1_epi16(0x7FFF), inf = _mm512_set1_epi16(0x7F80);
  alignas(64) float sums[32];
  // Columns outer, rows inner: each column's sum stays in a register over the block's rows.
  for (int64_t j = 0; j < vector_end; j += 32) {
    __m512 sum_low = _mm512_setzero_ps(), sum_high = _mm512_setzero_ps();
    for (int64_t r = r0; r < r1; ++r) {
      const int64_t i = r * a.m + j;
      const __m512i y = _mm512_loadu_si512(a.y + i);
      // !(y <= 0): positive (as a signed 16-bit integer) or NaN (either sign).
      const __mmask32 pass = _mm512_cmpgt_epi16_mask(y, zero) |
                             _mm512_cmpgt_epi16_mask(_mm512_and_si512(y, abs_mask), inf);
      // A plain load, then the mask: a masked load was several times slower on Zen 4 (measured).
      const __m512i g = _mm512_maskz_mov_epi16(pass, _mm512_loadu_si512(a.g + i));
      _mm512_storeu_si512(a.gz + i, g);
      __m512 low, high;
      unpack_bf16x32(g, low, high);
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

// gz (the ReLU's mask applied to g) and the bias gradient, float [m].
std::pair<torch::Tensor, torch::Tensor> relu_bias_backward(const torch::Tensor& g, const torch::Tensor& y) {
  const int64_t n = y.size(0), m = y.size(1);
  auto gz = torch::empty_like(y);
  const BackwardArgs args{bits_of(g), bits_of(y), bits_of(gz), m};
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
  auto bias_grad = torch::zeros({m}, torch::kFloat);
  float* total = bias_grad.data_ptr<float>();
  for (int64_t b = 0; b < blocks; ++b)
    for (int64_t j = 0; j < m; ++j) total[j] += partial[b * m + j];
  return {gz, bias_grad};
}

using torch::autograd::AutogradContext;
using torch::autograd::variable_list;

struct LinearReluFunction : public torch::autograd::Function<LinearReluFunction> {
  static torch::Tensor forward(AutogradContext* ctx, const torch::Tensor& x, const torch::Tensor& weight,
                               const torch::Tensor& bias) {
    auto y = torch::mm(x, weight.t());
    add_bias_relu_(y, bias.contiguous());
    ctx->save_for_backward({x, weight, y});
    return y;
  }

  static variable_list backward(AutogradContext* ctx, variable_list grads) {
    const auto saved = ctx->get_saved_variables();
    const auto& x = saved[0];
    const auto& weight = saved[1];
    const auto g = grads[0].to(torch::kBFloat16).contiguous();
    const auto [gz, bias_grad] = relu_bias_backward(g, saved[2]);
    torch::Tensor x_grad, weight_grad;
    if (ctx->needs_input_grad(0)) x_grad = torch::mm(gz, weight);
    if (ctx->needs_input_grad(1)) weight_grad = torch::mm(gz.t(), x);
    return {x_grad, weight_grad, ctx->needs_input_grad(2) ? bias_grad : torch::Tensor()};
  }
};

}  // namespace linear_relu_detail

void add_bias_relu_(torch::Tensor& y, const torch::Tensor& bias) {
  using namespace linear_relu_detail;
  TORCH_CHECK(y.dim() == 2 && y.scalar_type() == torch::kBFloat16 && y.is_contiguous() && y.is_cpu(),
              "add_bias_relu_: y must be a contiguous CPU bf16 [N, M] tensor, got ", y.scalar_type(), " ",
              y.sizes());
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
  const ForwardArgs args{bits_of(y), m, per_column ? bias.data_ptr<float>() : nullptr,
                         per_column ? nullptr : bits_of(bias)};
  const bool avx512 = use_avx512();
  // Each row is independent: any split over threads gives the same bits.
  at::parallel_for(0, n, kRowBlock / 4, [&](int64_t r0, int64_t r1) {
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
