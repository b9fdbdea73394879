#include "metrics/ssim.h"

#include <ATen/ATen.h>
#include <ATen/Parallel.h>

#include "core/error.h"
#include "metrics/separable_blur.h"

namespace handscs {

namespace {

void check_pair(const torch::Tensor& x, const torch::Tensor& y, const char* what) {
  TORCH_CHECK(x.dim() == 4, what, ": images must be [B, C, H, W], got ", x.sizes());
  TORCH_CHECK(x.sizes() == y.sizes(), what, ": image sizes differ: ", x.sizes(), " vs ", y.sizes());
  TORCH_CHECK(x.scalar_type() == y.scalar_type(), what, ": dtypes differ: ", x.scalar_type(),
              " vs ", y.scalar_type());
  TORCH_CHECK(x.size(2) >= kSsimWindow && x.size(3) >= kSsimWindow, what, ": images must be at least ",
              kSsimWindow, "x", kSsimWindow, ", got ", x.size(2), "x", x.size(3));
}

// The SSIM formula on one padding choice; differentiable through separable_blur.
torch::Tensor ssim_map_padded(const torch::Tensor& x, const torch::Tensor& y, int64_t pad) {
  const auto taps = gaussian_taps(kSsimWindow, kSsimSigma, x.scalar_type());
  const int64_t batch = x.size(0);
  // Two blur calls for the five local moments, grouped so that when only x needs gradients (the
  // training loss) backward blurs three moments, not five.
  const auto moments_x = separable_blur(at::cat({x, x * x, x * y}, 0), taps, pad);
  const auto moments_y = separable_blur(at::cat({y, y * y}, 0), taps, pad);
  const auto mu_x = moments_x.narrow(0, 0, batch);
  const auto mu_y = moments_y.narrow(0, 0, batch);
  const auto mu_xx = mu_x * mu_x;
  const auto mu_yy = mu_y * mu_y;
  const auto mu_xy = mu_x * mu_y;
  const auto sigma_xx = moments_x.narrow(0, batch, batch) - mu_xx;
  const auto sigma_yy = moments_y.narrow(0, batch, batch) - mu_yy;
  const auto sigma_xy = moments_x.narrow(0, 2 * batch, batch) - mu_xy;
  const double c1 = kSsimK1 * kSsimK1;
  const double c2 = kSsimK2 * kSsimK2;
  return ((2 * mu_xy + c1) * (2 * sigma_xy + c2)) / ((mu_xx + mu_yy + c1) * (sigma_xx + sigma_yy + c2));
}

// Values per parallel task of the direct path's passes: a few microseconds of work each, so that
// threads are only woken for images (a 512x334 RGB image is 31 tasks), not for tiny crops.
constexpr int64_t kValuesPerTask = 1 << 14;

// The same map without autograd (evaluation): the five moment images written in one pass, blurred
// in one call, and the formula in one pass, with each value's operations in the order of
// ssim_map_padded above, so bit-identical to it (tested); ~20 fewer image-sized temporaries. FMA
// contraction would round differently from LibTorch's separate kernels: it is off for this library
// (CMakeLists), whatever -march.
template <class T>
torch::Tensor ssim_map_padded_direct(const torch::Tensor& x_in, const torch::Tensor& y_in,
                                     int64_t pad) {
  const auto x = x_in.contiguous(), y = y_in.contiguous();
  const int64_t batch = x.size(0), n = x.numel();
  // [5B, C, H, W]: x, x x, x y, y, y y (the grouping of ssim_map_padded's two blur calls).
  auto planes = at::empty({5 * batch, x.size(1), x.size(2), x.size(3)}, x.options());
  const T* xp = x.data_ptr<T>();
  const T* yp = y.data_ptr<T>();
  T* pp = planes.data_ptr<T>();
  at::parallel_for(0, n, kValuesPerTask, [&](int64_t begin, int64_t end) {
    for (int64_t i = begin; i < end; ++i) {
      const T a = xp[i], b = yp[i];
      pp[i] = a;
      pp[n + i] = a * a;
      pp[2 * n + i] = a * b;
      pp[3 * n + i] = b;
      pp[4 * n + i] = b * b;
    }
  });
  const auto moments = separable_blur(planes, gaussian_taps(kSsimWindow, kSsimSigma, x.scalar_type()), pad);
  const int64_t m = moments.numel() / 5;  // values per moment after the blur
  auto out = at::empty({batch, moments.size(1), moments.size(2), moments.size(3)}, x.options());
  const T* mp = moments.data_ptr<T>();
  T* op = out.data_ptr<T>();
  const T c1 = static_cast<T>(kSsimK1 * kSsimK1);
  const T c2 = static_cast<T>(kSsimK2 * kSsimK2);
  at::parallel_for(0, m, kValuesPerTask, [&](int64_t begin, int64_t end) {
    for (int64_t i = begin; i < end; ++i) {
      const T mu_x = mp[i], mu_y = mp[3 * m + i];
      const T mu_xx = mu_x * mu_x, mu_yy = mu_y * mu_y, mu_xy = mu_x * mu_y;
      const T sigma_xx = mp[m + i] - mu_xx;
      const T sigma_yy = mp[4 * m + i] - mu_yy;
      const T sigma_xy = mp[2 * m + i] - mu_xy;
      op[i] = ((T(2) * mu_xy + c1) * (T(2) * sigma_xy + c2)) /
              ((mu_xx + mu_yy + c1) * (sigma_xx + sigma_yy + c2));
    }
  });
  return out;
}

// ssim_map_padded, or its direct form when nothing needs a gradient.
torch::Tensor ssim_map_any(const torch::Tensor& x, const torch::Tensor& y, int64_t pad) {
  const bool graph = at::GradMode::is_enabled() && (x.requires_grad() || y.requires_grad());
  if (graph) return ssim_map_padded(x, y, pad);
  if (x.scalar_type() == at::kDouble) return ssim_map_padded_direct<double>(x, y, pad);
  if (x.scalar_type() == at::kFloat) return ssim_map_padded_direct<float>(x, y, pad);
  return ssim_map_padded(x, y, pad);  // separable_blur names the unsupported dtype
}

}  // namespace

torch::Tensor rgb_to_gray_matlab(const torch::Tensor& rgb) {
  TORCH_CHECK(rgb.dim() == 4 && rgb.size(1) == 3, "rgb_to_gray_matlab: expected [B, 3, H, W], got ",
              rgb.sizes());
  // MATLAB's rgb2gray coefficients (the inverse of its NTSC YIQ matrix, first row), applied to uint8.
  const double coefficients[3] = {0.298936021293775, 0.587043074451121, 0.114020904255103};
  const auto quantised = (rgb.to(at::kDouble) * 255.0).round().clamp(0.0, 255.0);
  const auto gray = quantised.select(1, 0) * coefficients[0] +
                    quantised.select(1, 1) * coefficients[1] + quantised.select(1, 2) * coefficients[2];
  // rgb2gray on uint8 rounds to the nearest integer (no ties occur with these coefficients).
  return (gray.round().clamp(0.0, 255.0) / 255.0).unsqueeze(1);
}

torch::Tensor ssim_map(const torch::Tensor& x, const torch::Tensor& y, const SsimConfig& config) {
  check_pair(x, y, "ssim");
  switch (config.variant) {
    case SsimConfig::Variant::three_dgs:
      return ssim_map_any(x, y, kSsimWindow / 2);
    case SsimConfig::Variant::valid:
      return ssim_map_any(x, y, 0);
    case SsimConfig::Variant::matlab:
      // L = 255 on integer gray levels equals L = 1 on gray/255: C1, C2 scale with L^2.
      return ssim_map_any(rgb_to_gray_matlab(x), rgb_to_gray_matlab(y), 0).to(x.scalar_type());
  }
  throw Error("ssim: unknown variant");
}

torch::Tensor ssim(const torch::Tensor& x, const torch::Tensor& y, const SsimConfig& config) {
  return ssim_map(x, y, config).mean({1, 2, 3});
}

torch::Tensor ssim_loss(const torch::Tensor& pred, const torch::Tensor& target,
                        const SsimConfig& config) {
  return 1.0 - ssim(pred, target, config).mean();
}

}  // namespace handscs
