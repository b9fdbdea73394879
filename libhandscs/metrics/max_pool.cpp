#include "metrics/max_pool.h"

#include <algorithm>
#include <type_traits>
#include <vector>

#include <ATen/Parallel.h>

namespace handscs {

namespace {

// at::max_pool2d's rule: a NaN wins, then the larger value (branch-free, so loops vectorise).
template <class T>
inline T nan_max(T best, T v) {
  return (v > best || v != v) ? v : best;
}

// Rows of the window first (whole rows side by side), then across each output's columns: the
// same set of values per output, so the same maximum.
template <class T>
void pool_planes(const T* in, T* out, int64_t begin, int64_t end, int64_t height, int64_t width,
                 int64_t out_h, int64_t out_w, int64_t kernel, int64_t stride) {
  std::vector<T> column(width);
  T* c = column.data();
  for (int64_t plane = begin; plane < end; ++plane) {
    const T* src = in + plane * height * width;
    T* dst = out + plane * out_h * out_w;
    for (int64_t oy = 0; oy < out_h; ++oy) {
      const T* top = src + oy * stride * width;
#pragma omp simd
      for (int64_t x = 0; x < width; ++x) c[x] = top[x];
      for (int64_t ky = 1; ky < kernel; ++ky) {
        const T* row = top + ky * width;
#pragma omp simd
        for (int64_t x = 0; x < width; ++x) c[x] = nan_max(c[x], row[x]);
      }
      for (int64_t ox = 0; ox < out_w; ++ox) {
        const T* window = c + ox * stride;
        T best = window[0];
        for (int64_t kx = 1; kx < kernel; ++kx) best = nan_max(best, window[kx]);
        dst[oy * out_w + ox] = best;
      }
    }
  }
}

}  // namespace

torch::Tensor max_pool_2d(const torch::Tensor& x_in, int64_t kernel, int64_t stride) {
  TORCH_CHECK(x_in.dim() == 4, "max_pool_2d: expected [B, C, H, W], got ", x_in.sizes());
  TORCH_CHECK(kernel >= 1 && stride >= 1, "max_pool_2d: kernel and stride must be >= 1, got ",
              kernel, " and ", stride);
  TORCH_CHECK(x_in.size(2) >= kernel && x_in.size(3) >= kernel, "max_pool_2d: ", x_in.size(2), "x",
              x_in.size(3), " is smaller than the ", kernel, "x", kernel, " window");
  TORCH_CHECK(x_in.scalar_type() == torch::kFloat || x_in.scalar_type() == torch::kDouble,
              "max_pool_2d: float or double, got ", x_in.scalar_type());
  TORCH_CHECK(x_in.is_cpu(), "max_pool_2d: CPU tensors only");
  torch::NoGradGuard no_grad;
  const auto x = x_in.contiguous();
  const int64_t planes = x.size(0) * x.size(1), height = x.size(2), width = x.size(3);
  const int64_t out_h = (height - kernel) / stride + 1, out_w = (width - kernel) / stride + 1;
  auto out = torch::empty({x.size(0), x.size(1), out_h, out_w}, x.options());
  // Planes per task: about 4,096 outputs of work (an AlexNet plane at 512x334 is ~2,600), at least one.
  const int64_t grain = std::max<int64_t>(1, 4096 / std::max<int64_t>(1, out_h * out_w));
  auto run = [&](auto* in, auto* result) {
    using T = std::remove_pointer_t<decltype(result)>;
    at::parallel_for(0, planes, grain, [&](int64_t b, int64_t e) {
      pool_planes<T>(in, result, b, e, height, width, out_h, out_w, kernel, stride);
    });
  };
  if (x.scalar_type() == torch::kDouble)
    run(x.data_ptr<double>(), out.data_ptr<double>());
  else
    run(x.data_ptr<float>(), out.data_ptr<float>());
  return out;
}

torch::Tensor max_pool_2d_any(const torch::Tensor& x, int64_t kernel, int64_t stride) {
  if (torch::GradMode::is_enabled() && x.requires_grad())
    return at::max_pool2d(x, {kernel, kernel}, {stride, stride});
  return max_pool_2d(x, kernel, stride);
}

}  // namespace handscs
