// Lane helpers for per-item arithmetic written once as a template over its value type V: a plain
// float or double (one item), or Lanes16 (16 floats, one item per lane, AVX-512). The arithmetic
// operators work on both; what differs (sqrt, max, exp, select, constants, strided loads and
// stores) is here, with the same result per lane as the scalar form: sqrt and division are exact
// IEEE operations, max and select are comparisons, exp calls the same std::exp per lane. So a
// kernel instantiated for Lanes16 gives the scalar kernel's values bit for bit, provided neither
// contracts a * b + c into an FMA (compile such files with -ffp-contract=off).
//
// Templates instantiated for Lanes16 must be defined inside a `#pragma GCC target("avx512f")`
// region (include their .inc there), or GCC compiles them for the baseline target.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <type_traits>

#include "core/simd_level.h"

namespace handscs {

template <class V>
struct LaneTraits {  // plain float or double: one item
  using Element = V;
  static constexpr int kWidth = 1;
};

// c in every lane, rounded to the element type.
template <class V>
inline V lane_splat(double c) {
  return static_cast<V>(c);
}

inline float lane_sqrt(float v) { return std::sqrt(v); }
inline double lane_sqrt(double v) { return std::sqrt(v); }
inline float lane_max(float a, float b) { return std::max(a, b); }
inline double lane_max(double a, double b) { return std::max(a, b); }
inline float lane_exp(float v) { return std::exp(v); }
inline double lane_exp(double v) { return std::exp(v); }
// a >= b ? x : y.
inline float lane_select_ge(float a, float b, float x, float y) { return a >= b ? x : y; }
inline double lane_select_ge(double a, double b, double x, double y) { return a >= b ? x : y; }

// Lane l's value (one item: itself).
inline float lane_get(float v, int) { return v; }
inline double lane_get(double v, int) { return v; }

// v = p[0] (the stride is unused for one item); p[0] = v.
inline void lane_load(float& v, const float* p, int64_t) { v = *p; }
inline void lane_load(double& v, const double* p, int64_t) { v = *p; }
inline void lane_store(float v, float* p, int64_t) { *p = v; }
inline void lane_store(double v, double* p, int64_t) { *p = v; }

#pragma GCC push_options
#pragma GCC target("avx512f")

using Lanes16 = float __attribute__((vector_size(64)));

template <>
struct LaneTraits<Lanes16> {
  using Element = float;
  static constexpr int kWidth = 16;
};

template <>
inline Lanes16 lane_splat<Lanes16>(double c) {
  Lanes16 v;
  for (int l = 0; l < 16; ++l) v[l] = static_cast<float>(c);
  return v;
}
inline Lanes16 lane_sqrt(Lanes16 v) {
  for (int l = 0; l < 16; ++l) v[l] = std::sqrt(v[l]);
  return v;
}
// std::max(a, b) is (a < b) ? b : a, lane by lane (a NaN a stays).
inline Lanes16 lane_max(Lanes16 a, Lanes16 b) { return a < b ? b : a; }
inline Lanes16 lane_exp(Lanes16 v) {
  for (int l = 0; l < 16; ++l) v[l] = std::exp(v[l]);
  return v;
}
inline Lanes16 lane_select_ge(Lanes16 a, Lanes16 b, Lanes16 x, Lanes16 y) { return a >= b ? x : y; }

inline float lane_get(const Lanes16& v, int l) { return v[l]; }

// Lane l is p[l * stride].
inline void lane_load(Lanes16& v, const float* p, int64_t stride) {
  for (int l = 0; l < 16; ++l) v[l] = p[l * stride];
}
inline void lane_store(const Lanes16& v, float* p, int64_t stride) {
  for (int l = 0; l < 16; ++l) p[l * stride] = v[l];
}

#pragma GCC pop_options

// Whether kernels over T run 16 lanes at a time: float, at the active SIMD level AVX-512.
template <class T>
bool lanes16_active() {
  return std::is_same_v<T, float> && active_simd_level() == SimdLevel::avx512;
}

}  // namespace handscs
