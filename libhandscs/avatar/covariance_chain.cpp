#include "avatar/covariance_chain.h"

#include <cmath>
#include <tuple>
#include <vector>

#include <torch/csrc/autograd/custom_function.h>
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
// + raw[3..7]; `stride` between the raw values. r and e receive R(q) and exp(s).
template <class T>
void spd(const T* raw, int64_t stride, M3<T>& out, M3<T>& r, T e[3]) {
  quaternion_to_matrix<T>(1 + raw[3 * stride], raw[4 * stride], raw[5 * stride], raw[6 * stride], r);
  for (int i = 0; i < 3; ++i) e[i] = std::exp(raw[i * stride]);
  rotated_diagonal(r, e, out);
}

// m = r diag(e): column j of r scaled by e[j].
template <class T>
void scale_columns(const M3<T>& r, const T e[3], M3<T>& m) {
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) m[i][j] = r[i][j] * e[j];
}

// A row-major 3x3 from memory.
template <class T>
void load(const T* p, M3<T>& m) {
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) m[i][j] = p[3 * i + j];
}

template <class T>
void transpose(const M3<T>& a, M3<T>& out) {
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) out[i][j] = a[j][i];
}

template <class T>
void add_to(const M3<T>& a, M3<T>& out) {
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) out[i][j] += a[i][j];
}

// The backward of out = a b a^T: g_a = g a b^T + g^T a b (both terms, as autograd has them, b
// being symmetric only up to rounding), and g_b += a^T g a.
template <class T>
void sandwich_backward(const M3<T>& a, const M3<T>& b, const M3<T>& g, M3<T>& g_a, M3<T>& g_b) {
  M3<T> at, bt, gt, tmp, tmp2;
  transpose(a, at);
  transpose(b, bt);
  transpose(g, gt);
  product(g, a, tmp);
  product(tmp, bt, g_a);
  product(gt, a, tmp);
  product(tmp, b, tmp2);
  add_to(tmp2, g_a);
  product(at, g, tmp);
  product(tmp, a, tmp2);
  add_to(tmp2, g_b);
}

// The gradient with respect to the unnormalised quaternion (w, x, y, z) of render/rotation.h's
// R(q / |q|), given the gradient g of R; |q|^2 below the floor is a constant there, as in autograd.
template <class T>
void quaternion_to_matrix_backward(T w, T x, T y, T z, const M3<T>& g, T out[4]) {
  const T sq = w * w + x * x + y * y + z * z;
  const T floor = T(kQuaternionNormSquaredFloor);
  const T norm = std::sqrt(std::max<T>(sq, floor));
  w /= norm;
  x /= norm;
  y /= norm;
  z /= norm;
  // d R / d (w, x, y, z) of the normalised quaternion, term by term from quaternion_to_matrix.
  const T gw = 2 * (-z * g[0][1] + y * g[0][2] + z * g[1][0] - x * g[1][2] - y * g[2][0] + x * g[2][1]);
  const T gx = 2 * (y * g[0][1] + z * g[0][2] + y * g[1][0] - 2 * x * g[1][1] - w * g[1][2] + z * g[2][0] +
                    w * g[2][1] - 2 * x * g[2][2]);
  const T gy = 2 * (-2 * y * g[0][0] + x * g[0][1] + w * g[0][2] + x * g[1][0] + z * g[1][2] - w * g[2][0] +
                    z * g[2][1] - 2 * y * g[2][2]);
  const T gz = 2 * (-2 * z * g[0][0] - w * g[0][1] + x * g[0][2] + w * g[1][0] - 2 * z * g[1][1] + y * g[1][2] +
                    x * g[2][0] + y * g[2][1]);
  // Through q / |q|: (g - q_hat (q_hat . g)) / |q|, or g / |q| where the floor holds |q| fixed.
  const T dot = sq >= floor ? w * gw + x * gx + y * gy + z * gz : T(0);
  out[0] = (gw - w * dot) / norm;
  out[1] = (gx - x * dot) / norm;
  out[2] = (gy - y * dot) / norm;
  out[3] = (gz - z * dot) / norm;
}

// The gradient of M M^T with M = R diag(e) (both spd_from_raw's R diag(e) R^T, written as N R^T,
// and Sigma = (R diag(exp(s))) (R diag(exp(s)))^T): given the gradient `g_r` already collected for
// R elsewhere, adds d/dR, and writes d/d(log e) = e * d/de.
template <class T>
void scaled_rotation_backward(const M3<T>& r, const T e[3], const M3<T>& g_m, M3<T>& g_r, T g_log_e[3]) {
  for (int j = 0; j < 3; ++j) {
    T g_e = 0;
    for (int i = 0; i < 3; ++i) {
      g_r[i][j] += g_m[i][j] * e[j];
      g_e += g_m[i][j] * r[i][j];
    }
    g_log_e[j] = g_e * e[j];
  }
}

// spd_from_raw's backward: D = N R^T with N = R diag(e), e = exp(raw[0..3]), R = R(q), q = (1, 0,
// 0, 0) + raw[3..7]. Writes the 7 raw values' gradient (contiguous) from D's gradient g_d.
template <class T>
void spd_backward(const T* raw, int64_t stride, const M3<T>& r, const T e[3], const M3<T>& g_d, T* g_raw) {
  M3<T> n, g_n, g_r, g_dt;
  scale_columns(r, e, n);
  product(g_d, r, g_n);  // d/dN of N R^T
  transpose(g_d, g_dt);
  product(g_dt, n, g_r);  // d/dR through R^T
  scaled_rotation_backward(r, e, g_n, g_r, g_raw);
  quaternion_to_matrix_backward<T>(1 + raw[3 * stride], raw[4 * stride], raw[5 * stride], raw[6 * stride], g_r,
                                   g_raw + 3);
}

// One Gaussian's chain, forward: what it outputs and what its backward needs again.
template <class T>
struct ChainTerms {
  M3<T> ds, df;      // dSigma, dSigma^f
  M3<T> rg, rf, r;   // their rotations, and the Gaussian's own
  T eg[3], ef[3], e[3];  // exp of their log-scales, and of the Gaussian's
  M3<T> sigma, a, canonical, lin;  // Sigma, A = dSigma^f dSigma, A Sigma A^T, L
};

// q [4], s [3], L [9] of Gaussian k; the raw values with their column strides.
template <class T>
void chain_terms(const T* q, const T* s, const T* graw, int64_t g_col, const T* fraw, int64_t f_col, const T* l,
                 ChainTerms<T>& t) {
  spd<T>(graw, g_col, t.ds, t.rg, t.eg);
  spd<T>(fraw, f_col, t.df, t.rf, t.ef);
  quaternion_to_matrix<T>(q[0], q[1], q[2], q[3], t.r);
  T e2[3];  // diag(exp(s))^2
  for (int i = 0; i < 3; ++i) {
    t.e[i] = std::exp(s[i]);
    e2[i] = t.e[i] * t.e[i];
  }
  rotated_diagonal(t.r, e2, t.sigma);
  product(t.df, t.ds, t.a);
  sandwich(t.a, t.sigma, t.canonical);
  load(l, t.lin);
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
      ChainTerms<T> t;
      chain_terms<T>(qp + 4 * k, sp + 3 * k, gp + k * g_row, g_col, fp + k * f_row, f_col, lp + 9 * k, t);
      M3<T> posed;
      sandwich(t.lin, t.canonical, posed);
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) {
          dsp[9 * k + 3 * i + j] = t.ds[i][j];
          dfp[9 * k + 3 * i + j] = t.df[i][j];
          cp[9 * k + 3 * i + j] = t.canonical[i][j];
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

// The chain's backward, the forward recomputed per Gaussian. Incoming gradients: g_dsigma,
// g_dsigma_f, g_canonical [N, 3, 3], g_upper [N, 6] (contiguous). Outgoing: rotations [N, 4],
// log_scales [N, 3], geometry_raw and fusion_raw [N, 7], linear [N, 3, 3] (contiguous).
template <class T>
std::vector<torch::Tensor> run_backward(const torch::Tensor& rotations, const torch::Tensor& log_scales,
                                        const torch::Tensor& geometry_raw, const torch::Tensor& fusion_raw,
                                        const torch::Tensor& linear, const torch::Tensor& g_dsigma_in,
                                        const torch::Tensor& g_dsigma_f_in, const torch::Tensor& g_canonical_in,
                                        const torch::Tensor& g_upper_in) {
  const int64_t n = rotations.size(0);
  const auto opts = rotations.options();
  auto g_rotations = torch::empty({n, 4}, opts), g_log_scales = torch::empty({n, 3}, opts);
  auto g_geometry = torch::empty({n, 7}, opts), g_fusion = torch::empty({n, 7}, opts);
  auto g_linear = torch::empty({n, 3, 3}, opts);
  const auto q = rotations.contiguous(), s = log_scales.contiguous(), l = linear.contiguous();
  const auto gds = g_dsigma_in.contiguous(), gdf = g_dsigma_f_in.contiguous();
  const auto gc = g_canonical_in.contiguous(), gu = g_upper_in.contiguous();
  const T *qp = q.data_ptr<T>(), *sp = s.data_ptr<T>(), *lp = l.data_ptr<T>();
  const T *gp = geometry_raw.data_ptr<T>(), *fp = fusion_raw.data_ptr<T>();
  const int64_t g_row = geometry_raw.stride(0), g_col = geometry_raw.stride(1);
  const int64_t f_row = fusion_raw.stride(0), f_col = fusion_raw.stride(1);
  const T *gdsp = gds.data_ptr<T>(), *gdfp = gdf.data_ptr<T>(), *gcp = gc.data_ptr<T>(), *gup = gu.data_ptr<T>();
  T *oq = g_rotations.data_ptr<T>(), *os = g_log_scales.data_ptr<T>(), *ol = g_linear.data_ptr<T>();
  T *og = g_geometry.data_ptr<T>(), *of = g_fusion.data_ptr<T>();
  at::parallel_for(0, n, 256, [&](int64_t begin, int64_t end) {
    for (int64_t k = begin; k < end; ++k) {
      // Forward again.
      ChainTerms<T> t;
      chain_terms<T>(qp + 4 * k, sp + 3 * k, gp + k * g_row, g_col, fp + k * f_row, f_col, lp + 9 * k, t);
      const auto &ds = t.ds, &df = t.df, &r = t.r, &sigma = t.sigma, &a = t.a, &c = t.canonical, &lin = t.lin;

      // posed = L C L^T, its upper triangle taken entry by entry (avatar.cpp's symmetric_upper);
      // C's gradient adds to the one it receives as an output.
      const T* u = gup + 6 * k;
      const M3<T> g_p = {{u[0], u[1], u[2]}, {0, u[3], u[4]}, {0, 0, u[5]}};
      M3<T> tmp, g_l, g_c, g_a, g_sigma = {}, g_d, g_f;
      load(gcp + 9 * k, g_c);
      sandwich_backward(lin, c, g_p, g_l, g_c);
      sandwich_backward(a, sigma, g_c, g_a, g_sigma);  // C = A Sigma A^T
      // A = F D: dF = G_F + G_A D^T, dD = G_D + F^T G_A.
      M3<T> dst, dft;
      transpose(ds, dst);
      transpose(df, dft);
      load(gdfp + 9 * k, g_f);
      product(g_a, dst, tmp);
      add_to(tmp, g_f);
      load(gdsp + 9 * k, g_d);
      product(dft, g_a, tmp);
      add_to(tmp, g_d);
      spd_backward<T>(gp + k * g_row, g_col, t.rg, t.eg, g_d, og + 7 * k);
      spd_backward<T>(fp + k * f_row, f_col, t.rf, t.ef, g_f, of + 7 * k);
      // Sigma = M M^T: dM = (G_Sigma + G_Sigma^T) M, then M = R diag(exp(s)).
      M3<T> m, g_sym, g_m, g_r = {};
      scale_columns(r, t.e, m);
      transpose(g_sigma, g_sym);
      add_to(g_sigma, g_sym);
      product(g_sym, m, g_m);
      scaled_rotation_backward(r, t.e, g_m, g_r, os + 3 * k);
      quaternion_to_matrix_backward<T>(qp[4 * k], qp[4 * k + 1], qp[4 * k + 2], qp[4 * k + 3], g_r, oq + 4 * k);
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) ol[9 * k + 3 * i + j] = g_l[i][j];
    }
  });
  return {g_rotations, g_log_scales, g_geometry, g_fusion, g_linear};
}

using torch::autograd::AutogradContext;
using torch::autograd::variable_list;

struct CovarianceChainFunction : public torch::autograd::Function<CovarianceChainFunction> {
  static variable_list forward(AutogradContext* ctx, const torch::Tensor& rotations, const torch::Tensor& log_scales,
                               const torch::Tensor& geometry_raw, const torch::Tensor& fusion_raw,
                               const torch::Tensor& linear) {
    ctx->save_for_backward({rotations, log_scales, geometry_raw, fusion_raw, linear});
    const auto out = rotations.scalar_type() == torch::kDouble
                         ? run<double>(rotations, log_scales, geometry_raw, fusion_raw, linear)
                         : run<float>(rotations, log_scales, geometry_raw, fusion_raw, linear);
    return {out.dsigma, out.dsigma_f, out.canonical, out.posed_upper};
  }

  static variable_list backward(AutogradContext* ctx, variable_list grads) {
    const auto saved = ctx->get_saved_variables();
    const auto& rotations = saved[0];
    const auto args = std::make_tuple(saved[0], saved[1], saved[2], saved[3], saved[4], grads[0], grads[1],
                                      grads[2], grads[3]);
    return rotations.scalar_type() == torch::kDouble ? std::apply(run_backward<double>, args)
                                                     : std::apply(run_backward<float>, args);
  }
};

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
  const int64_t n = rotations.dim() == 2 ? rotations.size(0) : -1;
  const auto rows_of = [n](const torch::Tensor& t, std::initializer_list<int64_t> tail) {
    if (t.dim() != int64_t(tail.size()) + 1 || t.size(0) != n) return false;
    int64_t d = 1;
    for (const int64_t size : tail)
      if (t.size(d++) != size) return false;
    return true;
  };
  TORCH_CHECK(rows_of(rotations, {4}), "covariance_chain: rotations must be [N, 4], got ", rotations.sizes());
  TORCH_CHECK(rows_of(log_scales, {3}), "covariance_chain: log_scales must be [", n, ", 3], got ",
              log_scales.sizes());
  TORCH_CHECK(rows_of(geometry_raw, {7}), "covariance_chain: geometry_raw must be [", n, ", 7], got ",
              geometry_raw.sizes());
  TORCH_CHECK(rows_of(fusion_raw, {7}), "covariance_chain: fusion_raw must be [", n, ", 7], got ",
              fusion_raw.sizes());
  TORCH_CHECK(rows_of(linear, {3, 3}), "covariance_chain: linear must be [", n, ", 3, 3], got ", linear.sizes());
  const auto dtype = rotations.scalar_type();
  TORCH_CHECK((dtype == torch::kFloat || dtype == torch::kDouble) && log_scales.scalar_type() == dtype &&
                  geometry_raw.scalar_type() == dtype && fusion_raw.scalar_type() == dtype &&
                  linear.scalar_type() == dtype,
              "covariance_chain: one dtype, float or double, for every input; got rotations ", dtype,
              ", log_scales ", log_scales.scalar_type(), ", geometry_raw ", geometry_raw.scalar_type(),
              ", fusion_raw ", fusion_raw.scalar_type(), ", linear ", linear.scalar_type());
  TORCH_CHECK(rotations.is_cpu() && log_scales.is_cpu() && geometry_raw.is_cpu() && fusion_raw.is_cpu() &&
                  linear.is_cpu(),
              "covariance_chain: CPU tensors only");
  const bool graph = torch::GradMode::is_enabled() &&
                     (rotations.requires_grad() || log_scales.requires_grad() || geometry_raw.requires_grad() ||
                      fusion_raw.requires_grad() || linear.requires_grad());
  if (graph) {
    const auto out = CovarianceChainFunction::apply(rotations, log_scales, geometry_raw, fusion_raw, linear);
    return {out[0], out[1], out[2], out[3]};
  }
  torch::NoGradGuard no_grad;
  if (rotations.scalar_type() == torch::kDouble)
    return run<double>(rotations, log_scales, geometry_raw, fusion_raw, linear);
  return run<float>(rotations, log_scales, geometry_raw, fusion_raw, linear);
}

}  // namespace handscs
