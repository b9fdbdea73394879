#include "metrics/separable_blur.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <ATen/ATen.h>
#include <ATen/Dispatch.h>
#include <ATen/Parallel.h>
#include <torch/csrc/autograd/custom_function.h>

#include "core/simd_level.h"

namespace handscs {

namespace {

// Output values per parallel task: below this, threads cost more than they save.
constexpr int64_t kParallelThreshold = 1 << 15;

// One copy of the kernels per instruction set (FMA contraction is off for this library: CMakeLists).
namespace generic {
#include "metrics/separable_blur_rows.inc"
}  // namespace generic

#pragma GCC push_options
#pragma GCC target("avx2")
namespace avx2 {
#include "metrics/separable_blur_rows.inc"
}  // namespace avx2
#pragma GCC pop_options

#pragma GCC push_options
#pragma GCC target("avx512f")
namespace avx512 {
#include "metrics/separable_blur_rows.inc"
}  // namespace avx512
#pragma GCC pop_options

template <typename T>
using RowsFn = void (*)(const T*, T*, int64_t, int64_t, int64_t, int64_t, const T*, int64_t, int64_t);
template <typename T>
using ColumnsFn = void (*)(const T*, T*, int64_t, int64_t, int64_t, int64_t, int64_t, const T*, int64_t,
                           int64_t);

// Raw kernel. Pass 1 filters each row of `input` into `temp` ([planes, H, out_w]); pass 2 filters
// the columns of `temp` into `output` ([planes, out_h, out_w]). Zero padding is implicit: taps that
// fall outside the image are skipped. Never throws.
template <typename T>
void separable_blur_kernel(const T* input, T* temp, T* output, int64_t planes, int64_t height,
                           int64_t width, const T* taps, int64_t num_taps, int64_t pad) {
  const int64_t out_h = height + 2 * pad - num_taps + 1;
  const int64_t out_w = width + 2 * pad - num_taps + 1;
  RowsFn<T> rows_fn = &generic::blur_rows<T>;
  ColumnsFn<T> columns_fn = &generic::blur_columns<T>;
  switch (active_simd_level()) {
    case SimdLevel::avx512:
      rows_fn = &avx512::blur_rows<T>;
      columns_fn = &avx512::blur_columns<T>;
      break;
    case SimdLevel::avx2:
      rows_fn = &avx2::blur_rows<T>;
      columns_fn = &avx2::blur_columns<T>;
      break;
    default:
      break;
  }
  const int64_t rows = planes * height;
  at::parallel_for(0, rows, std::max<int64_t>(1, kParallelThreshold / out_w), [&](int64_t b, int64_t e) {
    rows_fn(input, temp, b, e, width, out_w, taps, num_taps, pad);
  });
  at::parallel_for(0, planes * out_h, std::max<int64_t>(1, kParallelThreshold / out_w),
                   [&](int64_t b, int64_t e) {
                     columns_fn(temp, output, b, e, height, out_h, out_w, taps, num_taps, pad);
                   });
}

torch::Tensor separable_blur_fwd(const torch::Tensor& input, const torch::Tensor& taps,
                                 int64_t pad) {
  const auto in = input.contiguous();
  const auto w = taps.contiguous();
  const int64_t batch = in.size(0), channels = in.size(1), height = in.size(2), width = in.size(3);
  const int64_t num_taps = w.size(0);
  const int64_t out_h = height + 2 * pad - num_taps + 1;
  const int64_t out_w = width + 2 * pad - num_taps + 1;
  auto output = at::empty({batch, channels, out_h, out_w}, in.options());
  auto temp = at::empty({batch * channels * height * out_w}, in.options());
  AT_DISPATCH_FLOATING_TYPES(in.scalar_type(), "separable_blur", [&] {
    separable_blur_kernel<scalar_t>(in.data_ptr<scalar_t>(), temp.data_ptr<scalar_t>(),
                                    output.data_ptr<scalar_t>(), batch * channels, height, width,
                                    w.data_ptr<scalar_t>(), num_taps, pad);
  });
  return output;
}

// Autograd glue. The adjoint of "correlate with taps after padding by p" is "correlate with the
// flipped taps after padding by K-1-p", so backward is the same op (and so twice differentiable).
class SeparableBlurFunction : public torch::autograd::Function<SeparableBlurFunction> {
 public:
  enum Slot { kInput, kTaps, kPad, kNumSlots };

  static torch::Tensor forward(torch::autograd::AutogradContext* ctx, const torch::Tensor& input,
                               const torch::Tensor& taps, int64_t pad) {
    ctx->save_for_backward({taps});
    ctx->saved_data["pad"] = pad;
    return separable_blur_fwd(input, taps, pad);
  }

  static torch::autograd::variable_list backward(torch::autograd::AutogradContext* ctx,
                                                 torch::autograd::variable_list grad_outputs) {
    const auto taps = ctx->get_saved_variables()[0];
    const int64_t pad = ctx->saved_data["pad"].toInt();
    torch::autograd::variable_list grads(kNumSlots);
    const auto& v_output = grad_outputs[0];
    if (v_output.defined())
      grads[kInput] = separable_blur(v_output, taps.flip({0}), taps.size(0) - 1 - pad);
    return grads;
  }
};

}  // namespace

torch::Tensor gaussian_taps(int64_t size, double sigma, torch::Dtype dtype) {
  TORCH_CHECK(size >= 1 && sigma > 0, "gaussian_taps: need size >= 1 and sigma > 0, got size ",
              size, ", sigma ", sigma);
  std::vector<double> taps(size);
  double sum = 0;
  const double centre = static_cast<double>(size / 2);
  for (int64_t k = 0; k < size; ++k) {
    taps[k] = std::exp(-(k - centre) * (k - centre) / (2 * sigma * sigma));
    sum += taps[k];
  }
  for (auto& t : taps) t /= sum;
  return torch::tensor(taps, torch::kDouble).to(dtype);
}

torch::Tensor separable_blur(const torch::Tensor& input, const torch::Tensor& taps, int64_t pad) {
  TORCH_CHECK(input.dim() == 4, "separable_blur: input must be [B, C, H, W], got ", input.sizes());
  TORCH_CHECK(input.scalar_type() == at::kFloat || input.scalar_type() == at::kDouble,
              "separable_blur: input must be float or double, got ", input.scalar_type());
  TORCH_CHECK(taps.dim() == 1 && taps.size(0) >= 1, "separable_blur: taps must be [K], got ",
              taps.sizes());
  TORCH_CHECK(taps.scalar_type() == input.scalar_type(), "separable_blur: taps dtype ",
              taps.scalar_type(), " differs from input dtype ", input.scalar_type());
  TORCH_CHECK(input.device().is_cpu() && taps.device().is_cpu(), "separable_blur: CPU tensors only");
  const int64_t num_taps = taps.size(0);
  TORCH_CHECK(pad >= 0 && pad <= num_taps - 1, "separable_blur: pad must be in [0, ", num_taps - 1,
              "], got ", pad);
  TORCH_CHECK(input.size(2) + 2 * pad >= num_taps && input.size(3) + 2 * pad >= num_taps,
              "separable_blur: image ", input.size(2), "x", input.size(3), " is smaller than the ",
              num_taps, "-tap window (pad ", pad, ")");
  return SeparableBlurFunction::apply(input, taps, pad);
}

}  // namespace handscs
