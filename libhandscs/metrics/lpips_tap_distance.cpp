#include "metrics/lpips_tap_distance.h"

#include <algorithm>
#include <cmath>
#include <type_traits>

#include <ATen/Parallel.h>

#include "metrics/lpips.h"

namespace handscs {

namespace {

// Pixels per task: one chunk's per-pixel norms (2 x 256 values, 4 KB in double) and its 256
// outputs stay in L1 while each channel's row of the chunk streams through; a chunk is at least
// 64 channels x 256 pixels of work (AlexNet's smallest tap), so every chunk is worth a task.
constexpr int64_t kChunkPixels = 256;

// Raw kernel for pixels [begin, end) of one batch item: fx, fy are its [C, pixels] features, out
// its [pixels] map. Channels outer, pixels inner, so every inner loop is a contiguous row. Never throws.
template <class T>
void tap_distance_chunk(const T* fx, const T* fy, const T* lin, T* out, int64_t channels,
                        int64_t pixels, int64_t begin, int64_t end) {
  const int64_t n = end - begin;
  T den_x[kChunkPixels], den_y[kChunkPixels];
  T* acc = out + begin;
  for (int64_t i = 0; i < n; ++i) den_x[i] = den_y[i] = acc[i] = T(0);
  // Pass 1: sum_c f^2 of both sides, then the denominators |f|_c + eps.
  for (int64_t c = 0; c < channels; ++c) {
    const T* x = fx + c * pixels + begin;
    const T* y = fy + c * pixels + begin;
#pragma omp simd
    for (int64_t i = 0; i < n; ++i) {
      den_x[i] += x[i] * x[i];
      den_y[i] += y[i] * y[i];
    }
  }
  const T eps = static_cast<T>(kLpipsNormEps);
#pragma omp simd
  for (int64_t i = 0; i < n; ++i) {
    // unit_normalize_channels' branch: a sum that is not > 0 (zero, or NaN) gives the norm 0.
    den_x[i] = (den_x[i] > T(0) ? std::sqrt(den_x[i]) : T(0)) + eps;
    den_y[i] = (den_y[i] > T(0) ? std::sqrt(den_y[i]) : T(0)) + eps;
  }
  // Pass 2: sum_c w_c (x / den_x - y / den_y)^2, the square before the weight as in square + conv.
  for (int64_t c = 0; c < channels; ++c) {
    const T* x = fx + c * pixels + begin;
    const T* y = fy + c * pixels + begin;
    const T w = lin[c];
#pragma omp simd
    for (int64_t i = 0; i < n; ++i) {
      const T d = x[i] / den_x[i] - y[i] / den_y[i];
      acc[i] += w * (d * d);
    }
  }
}

}  // namespace

torch::Tensor lpips_tap_distance(const torch::Tensor& fx_in, const torch::Tensor& fy_in,
                                 const torch::Tensor& lin_in) {
  TORCH_CHECK(fx_in.dim() == 4, "lpips_tap_distance: features must be [B, C, H, W], got ", fx_in.sizes());
  TORCH_CHECK(fx_in.sizes() == fy_in.sizes(), "lpips_tap_distance: feature sizes differ: ", fx_in.sizes(),
              " vs ", fy_in.sizes());
  TORCH_CHECK(lin_in.dim() == 1 && lin_in.size(0) == fx_in.size(1), "lpips_tap_distance: lin must be [",
              fx_in.size(1), "], got ", lin_in.sizes());
  TORCH_CHECK(fx_in.scalar_type() == torch::kFloat || fx_in.scalar_type() == torch::kDouble,
              "lpips_tap_distance: float or double, got ", fx_in.scalar_type());
  TORCH_CHECK(fy_in.scalar_type() == fx_in.scalar_type() && lin_in.scalar_type() == fx_in.scalar_type(),
              "lpips_tap_distance: dtypes differ: ", fx_in.scalar_type(), ", ", fy_in.scalar_type(), ", lin ",
              lin_in.scalar_type());
  TORCH_CHECK(fx_in.is_cpu() && fy_in.is_cpu() && lin_in.is_cpu(), "lpips_tap_distance: CPU tensors only");
  torch::NoGradGuard no_grad;
  const auto fx = fx_in.contiguous(), fy = fy_in.contiguous(), lin = lin_in.contiguous();
  const int64_t batch = fx.size(0), channels = fx.size(1), pixels = fx.size(2) * fx.size(3);
  auto out = torch::empty({batch, 1, fx.size(2), fx.size(3)}, fx.options());
  const int64_t chunks = (pixels + kChunkPixels - 1) / kChunkPixels;
  auto run = [&](auto* result) {
    using T = std::remove_pointer_t<decltype(result)>;
    const T* x = fx.data_ptr<T>();
    const T* y = fy.data_ptr<T>();
    const T* w = lin.data_ptr<T>();
    // Tasks are (batch item, chunk) pairs; each pixel is summed by one thread in channel order, so
    // the result does not depend on the thread count.
    at::parallel_for(0, batch * chunks, 1, [&](int64_t first, int64_t last) {
      for (int64_t task = first; task < last; ++task) {
        const int64_t b = task / chunks, begin = (task % chunks) * kChunkPixels;
        tap_distance_chunk<T>(x + b * channels * pixels, y + b * channels * pixels, w, result + b * pixels,
                              channels, pixels, begin, std::min(begin + kChunkPixels, pixels));
      }
    });
  };
  if (fx.scalar_type() == torch::kDouble)
    run(out.data_ptr<double>());
  else
    run(out.data_ptr<float>());
  return out;
}

}  // namespace handscs
