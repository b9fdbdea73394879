// Small double-precision 3-vector helpers (sum, difference, scaling, dot and cross products, length,
// unit vector) for the code that places cameras and hand parts in plain doubles: the built-in
// procedural hand, the synthetic capture generator, the orbit cameras of handscs-render and
// handscs-view, and the raster benchmark's hand scene.
#pragma once

#include <array>
#include <cmath>

namespace handscs {

using Vec3 = std::array<double, 3>;

inline Vec3 operator+(const Vec3& a, const Vec3& b) {
  return {a[0] + b[0], a[1] + b[1], a[2] + b[2]};
}
inline Vec3 operator-(const Vec3& a, const Vec3& b) {
  return {a[0] - b[0], a[1] - b[1], a[2] - b[2]};
}
inline Vec3 operator*(const Vec3& a, double s) { return {a[0] * s, a[1] * s, a[2] * s}; }
inline double dot(const Vec3& a, const Vec3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
inline Vec3 cross(const Vec3& a, const Vec3& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
inline double norm(const Vec3& a) { return std::sqrt(dot(a, a)); }
// The unit vector along a; the zero vector for a zero a (never a division by zero).
inline Vec3 normalized(const Vec3& a) {
  const double n = norm(a);
  return n > 0 ? a * (1.0 / n) : Vec3{0, 0, 0};
}

}  // namespace handscs
