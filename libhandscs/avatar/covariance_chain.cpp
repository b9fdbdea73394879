#include "avatar/covariance_chain.h"

#include <cmath>

#include <torch/types.h>

#include "avatar/avatar.h"
#include "render/rotation.h"

namespace handscs {

namespace {

template <class T>
using M3 = T[3][3];

// R diag(d) R^T.
template <class T>
void rotated_diagonal(const M3<T>& r, const T d[3], M3<T>& out) {
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) out[i][j] = r[i][0] * d[0] * r[j][0] + r[i][1] * d[1] * r[j][1] + r[i][2] * d[2] * r[j][2];
}

template <class T>
void product(const M3<T>& a, const M3<T>& b, M3<T>& out) {
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) out[i][j] = a[i][0] * b[0][j] + a[i][1] * b[1][j] + a[i][2] * b[2][j];
}

// a b a^T.
template <class T>
void sandwich(const M3<T>& a, const M3<T>& b, M3<T>& out) {
  M3<T> ab;
  product(a, b, ab);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) out[i][j] = ab[i][0] * a[j][0] + ab[i][1] * a[j][1] + ab[i][2] * a[j][2];
}

// SPD factor of 7 raw values (decoders' spd_from_raw): R(q) diag(exp(s)) R(q)^T, q = (1, 0, 0, 0)
// + raw[3..7]; `stride` between the raw values.
template <class T>
void spd(const T* raw, int64_t stride, M3<T>& out) {
  M3<T> r;
  quaternion_to_matrix<T>(1 + raw[3 * stride], raw[4 * stride], raw[5 * stride], raw[6 * stride], r);
  const T e[3] = {std::exp(raw[0]), std::exp(raw[stride]), std::exp(raw[2 * stride])};
  rotated_diagonal(r, e, out);
}

template <class T>
CovarianceChain run(const torch::Tensor& rotations, const torch::Tensor& log_scales,
                    const torch::Tensor& geometry_raw, const torch::Tensor& fusion_raw,
                    const torch::Tensor& linear) {
  const int64_t n = rotations.size(0);
  const auto opts = rotations.options();
  CovarianceChain out{torch::empty({n, 3, 3}, opts), torch::empty({n, 3, 3}, opts),
                      torch::empty({n, 3, 3}, opts), torch::empty({n, 6}, opts)};
  const auto q = rotations.contiguous(), s = log_scales.contiguous(), l = linear.contiguous();
  const T* qp = q.data_ptr<T>();
  const T* sp = s.data_ptr<T>();
  const T* lp = l.data_ptr<T>();
  const T* gp = geometry_raw.data_ptr<T>();
  const T* fp = fusion_raw.data_ptr<T>();
  const int64_t g_row = geometry_raw.stride(0), g_col = geometry_raw.stride(1);
  const int64_t f_row = fusion_raw.stride(0), f_col = fusion_raw.stride(1);
  T* dsp = out.dsigma.data_ptr<T>();
  T* dfp = out.dsigma_f.data_ptr<T>();
  T* cp = out.canonical.data_ptr<T>();
  T* up = out.posed_upper.data_ptr<T>();
  at::parallel_for(0, n, 256, [&](int64_t begin, int64_t end) {
    for (int64_t k = begin; k < end; ++k) {
      M3<T> ds, df, r, sigma, a, canonical, posed, lin;
      spd<T>(gp + k * g_row, g_col, ds);
      spd<T>(fp + k * f_row, f_col, df);
      quaternion_to_matrix<T>(qp[4 * k], qp[4 * k + 1], qp[4 * k + 2], qp[4 * k + 3], r);
      T e2[3];  // diag(exp(s))^2
      for (int i = 0; i < 3; ++i) e2[i] = std::exp(sp[3 * k + i]) * std::exp(sp[3 * k + i]);
      rotated_diagonal(r, e2, sigma);
      product(df, ds, a);
      sandwich(a, sigma, canonical);
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) lin[i][j] = lp[9 * k + 3 * i + j];
      sandwich(lin, canonical, posed);
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) {
          dsp[9 * k + 3 * i + j] = ds[i][j];
          dfp[9 * k + 3 * i + j] = df[i][j];
          cp[9 * k + 3 * i + j] = canonical[i][j];
        }
      T* u = up + 6 * k;
      u[0] = posed[0][0];
      u[1] = posed[0][1];
      u[2] = posed[0][2];
      u[3] = posed[1][1];
      u[4] = posed[1][2];
      u[5] = posed[2][2];
    }
  });
  return out;
}

}  // namespace

CovarianceChain covariance_chain_ops(const torch::Tensor& rotations, const torch::Tensor& log_scales,
                                     const torch::Tensor& dsigma, const torch::Tensor& dsigma_f,
                                     const torch::Tensor& linear) {
  const auto rot = quaternion_to_matrix(rotations);
  const auto scaled = rot * torch::exp(log_scales).unsqueeze(1);
  const auto sigma = scaled.matmul(scaled.transpose(1, 2));  // R S S R^T
  const auto a = dsigma_f.matmul(dsigma);                    // A = dSigma^f dSigma
  CovarianceChain out;
  out.dsigma = dsigma;
  out.dsigma_f = dsigma_f;
  out.canonical = a.matmul(sigma).matmul(a.transpose(1, 2));  // A Sigma A^T
  out.posed_upper = symmetric_upper(linear.matmul(out.canonical).matmul(linear.transpose(1, 2)));
  return out;
}

CovarianceChain covariance_chain(const torch::Tensor& rotations, const torch::Tensor& log_scales,
                                 const torch::Tensor& geometry_raw, const torch::Tensor& fusion_raw,
                                 const torch::Tensor& linear) {
  torch::NoGradGuard no_grad;
  if (rotations.scalar_type() == torch::kDouble)
    return run<double>(rotations, log_scales, geometry_raw, fusion_raw, linear);
  return run<float>(rotations, log_scales, geometry_raw, fusion_raw, linear);
}

}  // namespace handscs
