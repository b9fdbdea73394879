// Double-precision rotation helpers for the synthetic capture generator (R(axis, angle) by
// Rodrigues' formula; axis-angle from a rotation matrix), beside core/vec3.h's vector helpers, which
// it brings into handscs::synth.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>

#include "core/vec3.h"

namespace handscs::synth {

using handscs::cross;
using handscs::dot;
using handscs::norm;
using handscs::normalized;
using handscs::operator+;
using handscs::operator-;
using handscs::operator*;
using handscs::Vec3;
using Mat3 = std::array<double, 9>;  // row-major

inline Mat3 identity3() { return {1, 0, 0, 0, 1, 0, 0, 0, 1}; }

inline Mat3 mul(const Mat3& a, const Mat3& b) {
  Mat3 c{};
  for (int r = 0; r < 3; ++r)
    for (int k = 0; k < 3; ++k)
      for (int s = 0; s < 3; ++s) c[r * 3 + k] += a[r * 3 + s] * b[s * 3 + k];
  return c;
}

inline Vec3 mul(const Mat3& a, const Vec3& v) {
  return {a[0] * v[0] + a[1] * v[1] + a[2] * v[2], a[3] * v[0] + a[4] * v[1] + a[5] * v[2],
          a[6] * v[0] + a[7] * v[1] + a[8] * v[2]};
}

// Rotation by `angle` (rad) about the unit vector `axis`.
inline Mat3 rotation(const Vec3& axis, double angle) {
  const double c = std::cos(angle), s = std::sin(angle), t = 1 - c;
  const double x = axis[0], y = axis[1], z = axis[2];
  return {t * x * x + c,     t * x * y - s * z, t * x * z + s * y, t * x * y + s * z, t * y * y + c,
          t * y * z - s * x, t * x * z - s * y, t * y * z + s * x, t * z * z + c};
}

// Axis-angle vector (axis * angle) of a rotation matrix; angles stay below pi here.
inline Vec3 axis_angle(const Mat3& r) {
  const double cos_angle = std::clamp((r[0] + r[4] + r[8] - 1.0) * 0.5, -1.0, 1.0);
  const double angle = std::acos(cos_angle);
  const Vec3 w = {r[7] - r[5], r[2] - r[6], r[3] - r[1]};  // 2 sin(angle) axis
  const double s = std::sin(angle);
  if (s < 1e-9) return w * 0.5;  // small angle: R - R^T ~ 2 [w]x
  return w * (angle / (2.0 * s));
}

}  // namespace handscs::synth
