// Which instruction set the SIMD kernels (the rasterizer's tiles, the SSIM blur) run with: detected
// once at run time (AVX-512F, else AVX2+FMA, else the x86-64 baseline), so one binary runs
// everywhere. Tests and benchmarks may force a lower level.
#pragma once

#include <string>

namespace handscs {

enum class SimdLevel { generic = 0, avx2 = 1, avx512 = 2 };

// Best level this CPU supports.
SimdLevel detected_simd_level();
// Level the kernels use now (the detected one unless lowered by set_simd_level).
SimdLevel active_simd_level();
// Uses min(level, detected_simd_level()); returns the level now active. Not thread-safe against running kernels.
SimdLevel set_simd_level(SimdLevel level);
std::string simd_level_name(SimdLevel level);

}  // namespace handscs
