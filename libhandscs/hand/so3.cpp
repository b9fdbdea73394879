#include "hand/so3.h"

#include <algorithm>
#include <cmath>

namespace handscs {

namespace {

// Below this squared angle the series replace the closed forms: their first dropped terms are
// below double rounding there, and no sqrt is taken at zero.
constexpr double kSeriesBelow = 1e-4;

// a = sin t / t, b = (1 - cos t) / t^2 = sinc(t/2)^2 / 2 (no cancellation at small t) and
// c = (t - sin t) / t^3, from t^2.
struct Coefficients {
  double a, b, c;
};
Coefficients coefficients(double t2) {
  if (t2 < kSeriesBelow)
    return {1.0 - t2 / 6.0 + t2 * t2 / 120.0, 0.5 - t2 / 24.0 + t2 * t2 / 720.0,
            1.0 / 6.0 - t2 / 120.0 + t2 * t2 / 5040.0};
  const double t = std::sqrt(t2), half = 0.5 * t;
  const double sinc_half = std::sin(half) / half;
  return {std::sin(t) / t, 0.5 * sinc_half * sinc_half, (t - std::sin(t)) / (t2 * t)};
}

}  // namespace

Mat3 rodrigues_one(const double* v) {
  const double x = v[0], y = v[1], z = v[2];
  const double t2 = x * x + y * y + z * z;
  const Coefficients k = coefficients(t2);
  const double a = k.a, b = k.b;
  return {1.0 + b * (x * x - t2), b * x * y - a * z,        b * x * z + a * y,
          b * x * y + a * z,      1.0 + b * (y * y - t2),   b * y * z - a * x,
          b * x * z - a * y,      b * y * z + a * x,        1.0 + b * (z * z - t2)};
}

Mat3 right_jacobian(const double* v) {
  const double x = v[0], y = v[1], z = v[2];
  const double t2 = x * x + y * y + z * z;
  const Coefficients k = coefficients(t2);
  // K = [v]_x, K^2 = v v^T - t^2 I.
  const Mat3 K = {0, -z, y, z, 0, -x, -y, x, 0};
  const Mat3 K2 = {x * x - t2, x * y, x * z, x * y, y * y - t2, y * z, x * z, y * z, z * z - t2};
  Mat3 J{};
  for (int e = 0; e < 9; ++e) J[e] = (e % 4 == 0 ? 1.0 : 0.0) - k.b * K[e] + k.c * K2[e];
  return J;
}

Vec3 rotation_log(const Mat3& R) {
  const double trace = R[0] + R[4] + R[8];
  const double cos_t = std::clamp(0.5 * (trace - 1.0), -1.0, 1.0);
  const Vec3 w = {R[7] - R[5], R[2] - R[6], R[3] - R[1]};  // 2 sin t * axis
  const double sin_t = 0.5 * norm(w);
  const double t = std::atan2(sin_t, cos_t);
  if (t < 1e-6) return {0.5 * w[0], 0.5 * w[1], 0.5 * w[2]};  // sin t ~ t
  if (t < 3.0) {
    const double s = t / (2.0 * sin_t);
    return {s * w[0], s * w[1], s * w[2]};
  }
  // Near pi sin t loses precision: the axis from the diagonal of (R + I) / 2 = a a^T (approx).
  const double one_minus_cos = 1.0 - cos_t;
  Vec3 axis = {std::sqrt(std::max(0.0, (R[0] - cos_t) / one_minus_cos)),
                std::sqrt(std::max(0.0, (R[4] - cos_t) / one_minus_cos)),
                std::sqrt(std::max(0.0, (R[8] - cos_t) / one_minus_cos))};
  // Signs from the off-diagonal sums (relative to the largest component), then from w.
  const int big = axis[0] >= axis[1] && axis[0] >= axis[2] ? 0 : (axis[1] >= axis[2] ? 1 : 2);
  const Mat3 S = {0, R[1] + R[3], R[2] + R[6], R[1] + R[3], 0, R[5] + R[7], R[2] + R[6], R[5] + R[7], 0};
  for (int i = 0; i < 3; ++i)
    if (i != big && S[3 * big + i] < 0) axis[i] = -axis[i];
  if (dot(axis, w) < 0)
    for (double& a : axis) a = -a;
  const double n = norm(axis);
  return {t * axis[0] / n, t * axis[1] / n, t * axis[2] / n};
}

Mat3 mat_mul(const Mat3& a, const Mat3& b) {
  Mat3 out{};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      out[3 * i + j] = a[3 * i] * b[j] + a[3 * i + 1] * b[3 + j] + a[3 * i + 2] * b[6 + j];
  return out;
}

Mat3 mat_transpose(const Mat3& a) { return {a[0], a[3], a[6], a[1], a[4], a[7], a[2], a[5], a[8]}; }

Vec3 mat_vec(const Mat3& a, const Vec3& v) {
  return {a[0] * v[0] + a[1] * v[1] + a[2] * v[2], a[3] * v[0] + a[4] * v[1] + a[5] * v[2],
          a[6] * v[0] + a[7] * v[1] + a[8] * v[2]};
}

}  // namespace handscs
