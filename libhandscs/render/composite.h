// Front-to-back alpha compositing of binned splats per 16x16 tile (raw SIMD kernels), and its backward.
//   alpha_i = min(0.99, o_i exp(power_i)),  power_i = -0.5 (a dx^2 + c dy^2) - b dx dy,  (dx, dy) = pixel - mu_i
//   C = sum_i col_i alpha_i T_i + T_final bg,  A = 1 - T_final,  D = sum_i z_i alpha_i T_i.
// Backward (per pixel, back to front from the last contributor, T recovered by division):
//   T_i = T_{i+1} / (1 - alpha_i),  v_col_i += alpha_i T_i v_C,  v_z_i += alpha_i T_i v_D,
//   v_alpha_i = v_C . (col_i T_i - S_i / (1 - alpha_i)) + v_D (z_i T_i - S^D_i / (1 - alpha_i))
//               + T_final (v_A - bg . v_C) / (1 - alpha_i),   S_i = sum_{k > i} col_k alpha_k T_k,
//   and where o G <= 0.99 (no gradient through the cap): v_o += G v_alpha, v_power = o G v_alpha,
//   v_a = -0.5 dx^2 v_power, v_b = -dx dy v_power, v_c = -0.5 dy^2 v_power, v_mu = (a dx + b dy, b dx + c dy) v_power.
//
// Each thread owns whole tiles; gradients go to one slot per (tile, splat) entry, reduced per splat in entry
// order afterwards: no atomics, and results do not depend on the thread count. Never throws; no torch inside.
#pragma once

#include <cstdint>

#include "render/raster_frame.h"

namespace handscs {

// Alpha below 1/255 is invisible in an 8-bit image: skipped (as every 3DGS rasterizer does).
constexpr double kAlphaSkip = 1.0 / 255.0;
// Alpha cap: a single splat never makes a pixel fully opaque, so T stays invertible in the backward pass.
constexpr double kAlphaCap = 0.99;
// Blending stops before T would drop below 1e-4: the rest is invisible and T_i stays recoverable by division.
constexpr double kMinTransmittance = 1e-4;

template <class T>
struct CompositeInputs {
  const T* splats = nullptr;              // [n, kSplatFields]
  const int32_t* rects = nullptr;         // [n, kRectFields]
  const int32_t* tile_offsets = nullptr;  // [num_tiles + 1]
  const int32_t* tile_gaussians = nullptr;  // [entries]
  const int32_t* entry_slots = nullptr;     // [entries] gradient slot of each entry (backward only)
};

// Writes rgb [H, W, 3], alpha [H, W], depth [H, W] (accumulated z alpha T; nullptr = not computed), the final
// transmittance and the last contributor (1 + index within the tile list, 0 = none) per pixel.
// contributing_pairs (optional) receives the number of blended (pixel, splat) pairs.
template <class T>
void composite_fwd(const RasterFrame& frame, const CompositeInputs<T>& in, T* rgb, T* alpha, T* depth,
                   T* t_final, int32_t* last, int64_t* contributing_pairs = nullptr);

// Gradient of the splat records per entry, written to its slot: entry_grads [entries, kSplatGradFields] (every
// slot is written).
// v_rgb [H, W, 3], v_alpha [H, W], v_depth [H, W] may each be nullptr (zero).
template <class T>
void composite_bwd(const RasterFrame& frame, const CompositeInputs<T>& in, const T* t_final, const int32_t* last,
                   const T* v_rgb, const T* v_alpha, const T* v_depth, T* entry_grads);

// v_splats[i] = sum of splat i's slots [gaussian_offsets[i], gaussian_offsets[i + 1]) in order
// ([n, kSplatGradFields]).
template <class T>
void reduce_entry_grads(int64_t n, const int32_t* gaussian_offsets, const T* entry_grads, T* v_splats);

// The kernels' vector exp2 at the active SIMD level, on n floats (for accuracy tests).
void exp2_for_test(const float* x, float* y, int n);

}  // namespace handscs
