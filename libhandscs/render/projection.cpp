#include "render/projection.h"

#include <algorithm>
#include <cmath>

namespace handscs {

namespace {

// Low-pass dilation added to the projected covariance (pixels^2): every splat covers about one pixel, as in 3DGS.
constexpr double kDilation = 0.3;
// alpha below 1/255 is invisible in an 8-bit image and is skipped; a Gaussian with o < 1/255 never reaches it.
constexpr double kMinAlpha = 1.0 / 255.0;
// Extent safety margin (pixels): float rounding of the mean and conic moves the 1/255 contour by far less.
constexpr double kExtentMargin = 1e-2;
constexpr double kExtentRelMargin = 1e-4;
constexpr double kLn2 = 0.69314718055994530942;
// Below this many Gaussians the projection runs on the calling thread: the work (~0.1 us each) would not pay for
// waking the team, and on a busy machine every parallel region's barrier can cost a scheduler time slice.
constexpr int64_t kParallelMinGaussians = 2048;
constexpr double kLog2Of255 = 7.9943534368588578;

// Camera-space quantities of one Gaussian, shared by the forward and the backward pass.
struct Geometry {
  double p[3];          // camera-space mean
  double iz;            // 1 / z
  double uc, vc;        // clamped x/z, y/z used in the Jacobian
  bool u_clamped, v_clamped;
  double M[2][3];       // J R
  double sigma[3][3];   // world covariance (symmetric)
  double A, B, C;       // Sigma2D = [[A, B], [B, C]]
  double det;
};

template <class T>
bool finite_row(const T* v, int n) {
  for (int i = 0; i < n; ++i)
    if (!std::isfinite(v[i])) return false;
  return true;
}

// det(M S M^T) by the Cauchy-Binet formula, sum over column pairs P, Q of det(M[:, P]) det(S[P, Q]) det(M[:, Q]):
// for an ill-conditioned S (a 1e6 m^2 or 1e30 axis next to a 1e-4 one) A C - B^2 cancels catastrophically, this
// does not. det(Sigma2D) = det(M S M^T) + 0.3 (A0 + C0) + 0.09 for Sigma2D = M S M^T + 0.3 I.
double projected_det(const double M[2][3], const double S[3][3]) {
  static constexpr int kPairs[3][2] = {{0, 1}, {0, 2}, {1, 2}};
  double mu[3];
  for (int p = 0; p < 3; ++p) {
    const int i = kPairs[p][0], j = kPairs[p][1];
    mu[p] = M[0][i] * M[1][j] - M[0][j] * M[1][i];
  }
  double det = 0;
  for (int p = 0; p < 3; ++p)
    for (int q = 0; q < 3; ++q) {
      const int i = kPairs[p][0], j = kPairs[p][1], k = kPairs[q][0], l = kPairs[q][1];
      det += mu[p] * (S[i][k] * S[j][l] - S[i][l] * S[j][k]) * mu[q];
    }
  return det;
}

// Fills g; false when the Gaussian is culled by depth or by a projected covariance that is not positive definite.
template <class T>
bool compute_geometry(const RasterFrame& f, const T* m, const T* s, Geometry& g) {
  const auto& R = f.R;
  for (int i = 0; i < 3; ++i)
    g.p[i] = R[3 * i] * double(m[0]) + R[3 * i + 1] * double(m[1]) + R[3 * i + 2] * double(m[2]) + f.t[i];
  const double z = g.p[2];
  // Written positively so a NaN depth is culled too.
  if (!(z > f.near_plane && z <= f.far_plane)) return false;
  g.iz = 1.0 / z;
  const double u = g.p[0] * g.iz, v = g.p[1] * g.iz;
  g.u_clamped = u < f.u_lo || u > f.u_hi;
  g.v_clamped = v < f.v_lo || v > f.v_hi;
  g.uc = std::min(std::max(u, f.u_lo), f.u_hi);
  g.vc = std::min(std::max(v, f.v_lo), f.v_hi);
  const double j00 = f.fx * g.iz, j02 = -f.fx * g.uc * g.iz;
  const double j11 = f.fy * g.iz, j12 = -f.fy * g.vc * g.iz;
  for (int k = 0; k < 3; ++k) {
    g.M[0][k] = j00 * R[k] + j02 * R[6 + k];
    g.M[1][k] = j11 * R[3 + k] + j12 * R[6 + k];
  }
  const double xx = s[0], xy = s[1], xz = s[2], yy = s[3], yz = s[4], zz = s[5];
  const double S[3][3] = {{xx, xy, xz}, {xy, yy, yz}, {xz, yz, zz}};
  std::copy(&S[0][0], &S[0][0] + 9, &g.sigma[0][0]);
  double MS[2][3];
  for (int i = 0; i < 2; ++i)
    for (int k = 0; k < 3; ++k) MS[i][k] = g.M[i][0] * S[0][k] + g.M[i][1] * S[1][k] + g.M[i][2] * S[2][k];
  const double a0 = MS[0][0] * g.M[0][0] + MS[0][1] * g.M[0][1] + MS[0][2] * g.M[0][2];
  const double c0 = MS[1][0] * g.M[1][0] + MS[1][1] * g.M[1][1] + MS[1][2] * g.M[1][2];
  g.A = a0 + kDilation;
  g.B = MS[0][0] * g.M[1][0] + MS[0][1] * g.M[1][1] + MS[0][2] * g.M[1][2];
  g.C = c0 + kDilation;
  g.det = projected_det(g.M, S) + kDilation * (a0 + c0) + kDilation * kDilation;
  return g.A > 0 && g.C > 0 && g.det > 0 && std::isfinite(g.det) && std::isfinite(1.0 / g.det);
}

// Inclusive pixel index range [lo, hi) whose centres i + 0.5 lie within centre +- extent, clipped to [0, size).
void pixel_range(double centre, double extent, int size, int32_t& lo, int32_t& hi) {
  const double margin = kExtentMargin + kExtentRelMargin * extent;
  double a = std::ceil(centre - extent - margin - 0.5);
  double b = std::floor(centre + extent + margin - 0.5) + 1.0;
  a = std::min(std::max(a, 0.0), double(size));
  b = std::min(std::max(b, 0.0), double(size));
  lo = int32_t(a);
  hi = int32_t(b);
}

template <class T>
void project_one(const RasterFrame& f, int64_t i, const T* means, const T* covs, const T* colors,
                 const T* opacities, const T* probe, T* splat, int32_t* rect, int32_t* radius) {
  std::fill(splat, splat + kSplatFields, T(0));
  rect[kRectX0] = rect[kRectX1] = rect[kRectY0] = rect[kRectY1] = 0;
  *radius = 0;
  const T* m = means + 3 * i;
  const T* s = covs + 6 * i;
  const T* c = colors + 3 * i;
  const double o = opacities[i];
  if (!finite_row(m, 3) || !finite_row(s, 6) || !finite_row(c, 3) || !std::isfinite(o)) return;
  if (probe && !finite_row(probe + 2 * i, 2)) return;
  if (!(o >= kMinAlpha)) return;
  Geometry g;
  if (!compute_geometry(f, m, s, g)) return;
  double mx = f.fx * g.p[0] * g.iz + f.cx - f.x0;
  double my = f.fy * g.p[1] * g.iz + f.cy - f.y0;
  if (probe) {
    mx += double(probe[2 * i]);
    my += double(probe[2 * i + 1]);
  }
  if (!std::isfinite(mx) || !std::isfinite(my)) return;
  // Opacity-aware extent: o G >= 1/255  <=>  d^T conic d <= 2 ln(255 o); the ellipse's bounding box has
  // half-widths sqrt(q Sigma2D_xx), sqrt(q Sigma2D_yy).
  const double log2o = std::log2(o);
  const double q = 2.0 * kLn2 * (log2o + kLog2Of255);
  const double ex = std::sqrt(std::max(q, 0.0) * g.A), ey = std::sqrt(std::max(q, 0.0) * g.C);
  int32_t x0, x1, y0, y1;
  pixel_range(mx, ex, f.width, x0, x1);
  pixel_range(my, ey, f.height, y0, y1);
  if (x0 >= x1 || y0 >= y1) return;
  rect[kRectX0] = x0;
  rect[kRectX1] = x1;
  rect[kRectY0] = y0;
  rect[kRectY1] = y1;
  *radius = int32_t(std::min(std::ceil(std::max(ex, ey)), 1e9));
  if (*radius < 1) *radius = 1;  // visible: a radius of 0 means culled
  const double inv_det = 1.0 / g.det;
  splat[kSplatX] = T(mx);
  splat[kSplatY] = T(my);
  splat[kSplatConicA] = T(g.C * inv_det);
  splat[kSplatConicB] = T(-g.B * inv_det);
  splat[kSplatConicC] = T(g.A * inv_det);
  splat[kSplatOpacity] = T(o);
  splat[kSplatLog2Opacity] = T(log2o);
  for (int k = 0; k < 3; ++k) splat[kSplatRed + k] = std::min(std::max(c[k], T(0)), T(1));
  splat[kSplatDepth] = T(g.p[2]);
}

template <class T>
void unproject_one(const RasterFrame& f, int64_t i, const T* means, const T* covs, const T* colors,
                   const T* v_splat, T* v_mean, T* v_cov, T* v_color, T* v_opacity, T* v_probe) {
  Geometry g;
  compute_geometry(f, means + 3 * i, covs + 6 * i, g);
  const double v_mx = v_splat[kSplatX], v_my = v_splat[kSplatY];
  const double va = v_splat[kSplatConicA], vb = v_splat[kSplatConicB], vc = v_splat[kSplatConicC];
  // conic = Sigma2D^-1: dL/dSigma2D = -conic G conic with G the symmetric matrix gradient of the conic,
  // whose off-diagonal entries are vb / 2 each (vb is d/db with b in both positions).
  const double inv_det = 1.0 / g.det;
  const double ca = g.C * inv_det, cb = -g.B * inv_det, cc = g.A * inv_det;
  const double hb = 0.5 * vb;
  const double x00 = ca * va + cb * hb, x01 = ca * hb + cb * vc;  // X = conic G
  const double x10 = cb * va + cc * hb, x11 = cb * hb + cc * vc;
  const double s00 = -(x00 * ca + x01 * cb);  // dL/dSigma2D = -X conic (symmetric)
  const double s01 = -(x00 * cb + x01 * cc);
  const double s11 = -(x10 * cb + x11 * cc);
  const double VS[2][2] = {{s00, s01}, {s01, s11}};
  // Sigma2D = M Sigma M^T: dL/dSigma = M^T VS M, dL/dM = 2 VS M Sigma.
  double VSM[2][3];
  for (int i2 = 0; i2 < 2; ++i2)
    for (int k = 0; k < 3; ++k) VSM[i2][k] = VS[i2][0] * g.M[0][k] + VS[i2][1] * g.M[1][k];
  double VSig[3][3];
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) VSig[a][b] = g.M[0][a] * VSM[0][b] + g.M[1][a] * VSM[1][b];
  // 6-parameter convention: an off-diagonal parameter appears twice in Sigma, so its gradient is the sum.
  v_cov[0] = T(VSig[0][0]);
  v_cov[1] = T(VSig[0][1] + VSig[1][0]);
  v_cov[2] = T(VSig[0][2] + VSig[2][0]);
  v_cov[3] = T(VSig[1][1]);
  v_cov[4] = T(VSig[1][2] + VSig[2][1]);
  v_cov[5] = T(VSig[2][2]);
  double VM[2][3];
  for (int i2 = 0; i2 < 2; ++i2)
    for (int k = 0; k < 3; ++k)
      VM[i2][k] = 2.0 * (VSM[i2][0] * g.sigma[0][k] + VSM[i2][1] * g.sigma[1][k] + VSM[i2][2] * g.sigma[2][k]);
  // M = J R: dL/dJ = VM R^T; J01 = J10 = 0 are constants.
  const auto& R = f.R;
  const double vj00 = VM[0][0] * R[0] + VM[0][1] * R[1] + VM[0][2] * R[2];
  const double vj02 = VM[0][0] * R[6] + VM[0][1] * R[7] + VM[0][2] * R[8];
  const double vj11 = VM[1][0] * R[3] + VM[1][1] * R[4] + VM[1][2] * R[5];
  const double vj12 = VM[1][0] * R[6] + VM[1][1] * R[7] + VM[1][2] * R[8];
  const double x = g.p[0], y = g.p[1], iz = g.iz, iz2 = iz * iz, iz3 = iz2 * iz;
  double vx = 0, vy = 0, vz = 0;
  vz += -f.fx * iz2 * vj00 - f.fy * iz2 * vj11;
  if (g.u_clamped) {
    vz += f.fx * g.uc * iz2 * vj02;  // J02 = -fx uc / z with uc constant
  } else {
    vx += -f.fx * iz2 * vj02;  // J02 = -fx x / z^2
    vz += 2.0 * f.fx * x * iz3 * vj02;
  }
  if (g.v_clamped) {
    vz += f.fy * g.vc * iz2 * vj12;
  } else {
    vy += -f.fy * iz2 * vj12;
    vz += 2.0 * f.fy * y * iz3 * vj12;
  }
  // mu2D = (fx x/z + cx, fy y/z + cy).
  vx += f.fx * iz * v_mx;
  vy += f.fy * iz * v_my;
  vz += -(f.fx * x * v_mx + f.fy * y * v_my) * iz2;
  vz += double(v_splat[kSplatDepth]);
  for (int k = 0; k < 3; ++k) v_mean[k] = T(R[k] * vx + R[3 + k] * vy + R[6 + k] * vz);
  for (int k = 0; k < 3; ++k) {
    const T ck = colors[3 * i + k];
    v_color[k] = (ck >= T(0) && ck <= T(1)) ? v_splat[kSplatRed + k] : T(0);
  }
  *v_opacity = v_splat[kSplatOpacity];
  if (v_probe) {
    v_probe[0] = T(v_mx);
    v_probe[1] = T(v_my);
  }
}

}  // namespace

template <class T>
void project_fwd(const RasterFrame& frame, int64_t n, const T* means, const T* covs, const T* colors,
                 const T* opacities, const T* probe, T* splats, int32_t* rects, int32_t* radii) {
#pragma omp parallel for schedule(static) if (n >= kParallelMinGaussians)
  for (int64_t i = 0; i < n; ++i)
    project_one(frame, i, means, covs, colors, opacities, probe, splats + kSplatFields * i, rects + kRectFields * i,
                radii + i);
}

template <class T>
void project_bwd(const RasterFrame& frame, int64_t n, const T* means, const T* covs, const T* colors,
                 const int32_t* radii, const T* v_splats, T* v_means, T* v_covs, T* v_colors, T* v_opacities,
                 T* v_probe) {
#pragma omp parallel for schedule(static) if (n >= kParallelMinGaussians)
  for (int64_t i = 0; i < n; ++i) {
    if (radii[i] <= 0) {
      std::fill(v_means + 3 * i, v_means + 3 * i + 3, T(0));
      std::fill(v_covs + 6 * i, v_covs + 6 * i + 6, T(0));
      std::fill(v_colors + 3 * i, v_colors + 3 * i + 3, T(0));
      v_opacities[i] = T(0);
      if (v_probe) v_probe[2 * i] = v_probe[2 * i + 1] = T(0);
      continue;
    }
    unproject_one(frame, i, means, covs, colors, v_splats + kSplatGradFields * i, v_means + 3 * i, v_covs + 6 * i,
                  v_colors + 3 * i, v_opacities + i, v_probe ? v_probe + 2 * i : nullptr);
  }
}

template void project_fwd<float>(const RasterFrame&, int64_t, const float*, const float*, const float*,
                                 const float*, const float*, float*, int32_t*, int32_t*);
template void project_fwd<double>(const RasterFrame&, int64_t, const double*, const double*, const double*,
                                  const double*, const double*, double*, int32_t*, int32_t*);
template void project_bwd<float>(const RasterFrame&, int64_t, const float*, const float*, const float*,
                                 const int32_t*, const float*, float*, float*, float*, float*, float*);
template void project_bwd<double>(const RasterFrame&, int64_t, const double*, const double*, const double*,
                                  const int32_t*, const double*, double*, double*, double*, double*, double*);

}  // namespace handscs
