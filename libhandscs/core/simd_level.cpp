#include "core/simd_level.h"

#include <algorithm>
#include <atomic>

namespace handscs {

namespace {

SimdLevel detect() {
  __builtin_cpu_init();
  if (__builtin_cpu_supports("avx512f")) return SimdLevel::avx512;
  if (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma")) return SimdLevel::avx2;
  return SimdLevel::generic;
}

std::atomic<int>& active() {
  static std::atomic<int> level{static_cast<int>(detected_simd_level())};
  return level;
}

}  // namespace

SimdLevel detected_simd_level() {
  static const SimdLevel level = detect();
  return level;
}

SimdLevel active_simd_level() { return static_cast<SimdLevel>(active().load(std::memory_order_relaxed)); }

SimdLevel set_simd_level(SimdLevel level) {
  const int chosen = std::min(static_cast<int>(level), static_cast<int>(detected_simd_level()));
  active().store(chosen, std::memory_order_relaxed);
  return static_cast<SimdLevel>(chosen);
}

std::string simd_level_name(SimdLevel level) {
  switch (level) {
    case SimdLevel::avx512: return "avx512";
    case SimdLevel::avx2: return "avx2";
    default: return "generic";
  }
}

}  // namespace handscs
