// Tile compositing kernels, instantiated once per instruction set: composite_tiles.inc on the Ops of
// simd_ops.inc, compiled inside `#pragma GCC target` regions (generic x86-64, AVX2+FMA, AVX-512F) and chosen at run
// time (simd_level.h), so one binary runs on any x86-64 and uses AVX-512 where it exists.
// This file is compiled with -ffp-contract=off (libhandscs/CMakeLists.txt): the backward pass recomputes every
// alpha and its 1/255 and 0.99 decisions, which must match the forward pass bit for bit, so the only fused
// multiply-adds are the explicit Ops::fmadd calls, which both passes make identically. AVX2 and AVX-512 give
// identical forward results; the generic level has no FMA and differs by rounding.
//
// GCC 12's AVX-512 intrinsic headers trip -Wmaybe-uninitialized on their own "undefined" pass-through operands
// (GCC bug 105593, fixed in 12.3); the pragma must precede the header to cover it.
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#include <immintrin.h>

#include "render/composite.h"

#include <algorithm>
#include <cmath>
#include <vector>


#include "render/projection.h"
#include "core/simd_level.h"

namespace handscs {

namespace {

constexpr int kPixels = kTileSize * kTileSize;

template <class T>
struct FwdArgs {
  const RasterFrame* frame;
  CompositeInputs<T> in;
  T* rgb;
  T* alpha;
  T* depth;
  T* t_final;
  int32_t* last;
};

template <class T>
struct BwdArgs {
  const RasterFrame* frame;
  CompositeInputs<T> in;
  const T* t_final;
  const int32_t* last;
  const T* v_rgb;
  const T* v_alpha;
  const T* v_depth;
  T* entry_grads;
};

// Tile geometry: origin (region-local pixels) and the valid extent (partial tiles at the right/bottom edges).
struct TileBox {
  int x0, y0, w, h;
};

inline TileBox tile_box(const RasterFrame& f, int tile) {
  const int x0 = (tile % f.tiles_x) * kTileSize, y0 = (tile / f.tiles_x) * kTileSize;
  return {x0, y0, std::min(kTileSize, f.width - x0), std::min(kTileSize, f.height - y0)};
}

constexpr double kLog2e = 1.4426950408889634074;

// A splat's constants in one tile: rows [r0, r1) and chunks [k0, k1] (chunk = L pixels of a row) it overlaps.
template <class T>
struct SplatCoeffs {
  T mx, my, qa, qb, qc, log2o;
  int r0, r1, k0, k1;
};

template <class T>
inline SplatCoeffs<T> splat_coeffs(const T* s, const int32_t* rc, const TileBox& box, int lanes) {
  SplatCoeffs<T> v;
  v.mx = s[kSplatX];
  v.my = s[kSplatY];
  v.qa = s[kSplatConicA] * T(-0.5 * kLog2e);
  v.qb = s[kSplatConicB] * T(-kLog2e);
  v.qc = s[kSplatConicC] * T(-0.5 * kLog2e);
  v.log2o = s[kSplatLog2Opacity];
  v.r0 = std::max(rc[kRectY0] - box.y0, 0);
  v.r1 = std::min(rc[kRectY1] - box.y0, box.h);
  v.k0 = std::max(rc[kRectX0] - box.x0, 0) / lanes;
  v.k1 = (std::min(rc[kRectX1] - box.x0, box.w) - 1) / lanes;
  return v;
}

// The dy-dependent scalars of a splat's exp2 argument in tile row r: x = dx (qa dx + lin) + cst. Scalar code
// without FMA contraction (this file is compiled with -ffp-contract=off): both passes get identical values.
template <class T>
struct RowTerms {
  T dy, lin, cst;
};

template <class T>
inline RowTerms<T> row_terms(T my, T qb, T qc, T log2o, const TileBox& box, int r) {
  const T dy = (T(box.y0 + r) + T(0.5)) - my;
  return {dy, qb * dy, qc * dy * dy + log2o};
}

// One set of tile functions per instruction set; lanes per register: a 16-pixel tile row is 16 / L chunks.
template <class T>
using TileFwdFn = int64_t (*)(const FwdArgs<T>&, int, bool, bool);
template <class T>
using TileBwdFn = void (*)(const BwdArgs<T>&, int, bool);

namespace generic {
#define HANDSCS_SIMD_LEVEL 0
#include "render/simd_ops.inc"
#include "render/composite_tiles.inc"
#undef HANDSCS_SIMD_LEVEL
}  // namespace generic

#pragma GCC push_options
#pragma GCC target("avx2,fma")
namespace avx2 {
#define HANDSCS_SIMD_LEVEL 1
#include "render/simd_ops.inc"
#include "render/composite_tiles.inc"
#undef HANDSCS_SIMD_LEVEL
}  // namespace avx2
#pragma GCC pop_options

#pragma GCC push_options
#pragma GCC target("avx512f")
namespace avx512 {
#define HANDSCS_SIMD_LEVEL 2
#include "render/simd_ops.inc"
#include "render/composite_tiles.inc"
#undef HANDSCS_SIMD_LEVEL
}  // namespace avx512
#pragma GCC pop_options

template <class T>
TileFwdFn<T> pick_fwd() {
  switch (active_simd_level()) {
    case SimdLevel::avx512: return static_cast<TileFwdFn<T>>(&avx512::fwd);
    case SimdLevel::avx2: return static_cast<TileFwdFn<T>>(&avx2::fwd);
    default: return static_cast<TileFwdFn<T>>(&generic::fwd);
  }
}

template <class T>
TileBwdFn<T> pick_bwd() {
  switch (active_simd_level()) {
    case SimdLevel::avx512: return static_cast<TileBwdFn<T>>(&avx512::bwd);
    case SimdLevel::avx2: return static_cast<TileBwdFn<T>>(&avx2::bwd);
    default: return static_cast<TileBwdFn<T>>(&generic::bwd);
  }
}

}  // namespace

// Tiles in decreasing order of list length: with dynamic scheduling the long tiles start first and the short
// ones fill the gaps, so threads finish together (a dense hand puts most of the work in a few tiles). Each tile
// writes only its own pixels and gradient slots, so the order changes no result.
// Small frames (fewer entries than this, or a single tile) are composited on the calling thread: waking the team
// costs more than the work, and on a busy machine a barrier can cost a scheduler time slice.
constexpr int32_t kParallelMinEntries = 1024;
// The per-splat gradient sum is ~10 adds per entry: below this many splats it stays on the calling thread.
constexpr int64_t kParallelMinSplats = 4096;

static bool worth_parallel(const RasterFrame& frame, const int32_t* tile_offsets) {
  return frame.num_tiles() > 1 && tile_offsets[frame.num_tiles()] >= kParallelMinEntries;
}

static std::vector<int> tiles_by_cost(const RasterFrame& frame, const int32_t* tile_offsets) {
  std::vector<int> order(frame.num_tiles());
  for (int k = 0; k < frame.num_tiles(); ++k) order[k] = k;
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    return tile_offsets[a + 1] - tile_offsets[a] > tile_offsets[b + 1] - tile_offsets[b];
  });
  return order;
}

template <class T>
void composite_fwd(const RasterFrame& frame, const CompositeInputs<T>& in, T* rgb, T* alpha, T* depth,
                   T* t_final, int32_t* last, int64_t* contributing_pairs) {
  const std::vector<int> order = tiles_by_cost(frame, in.tile_offsets);
  const FwdArgs<T> args{&frame, in, rgb, alpha, depth, t_final, last};
  const TileFwdFn<T> fn = pick_fwd<T>();
  const bool with_depth = depth != nullptr, count = contributing_pairs != nullptr;
  const int num_tiles = frame.num_tiles();
  int64_t blended = 0;
  const bool parallel = worth_parallel(frame, in.tile_offsets);
#pragma omp parallel for schedule(dynamic, 1) reduction(+ : blended) if (parallel)
  for (int k = 0; k < num_tiles; ++k) blended += fn(args, order[k], with_depth, count);
  if (contributing_pairs) *contributing_pairs = blended;
}

template <class T>
void composite_bwd(const RasterFrame& frame, const CompositeInputs<T>& in, const T* t_final, const int32_t* last,
                   const T* v_rgb, const T* v_alpha, const T* v_depth, T* entry_grads) {
  const std::vector<int> order = tiles_by_cost(frame, in.tile_offsets);
  const BwdArgs<T> args{&frame, in, t_final, last, v_rgb, v_alpha, v_depth, entry_grads};
  const TileBwdFn<T> fn = pick_bwd<T>();
  const bool with_depth = v_depth != nullptr;
  const int num_tiles = frame.num_tiles();
  const bool parallel = worth_parallel(frame, in.tile_offsets);
#pragma omp parallel for schedule(dynamic, 1) if (parallel)
  for (int k = 0; k < num_tiles; ++k) fn(args, order[k], with_depth);
}

template <class T>
void reduce_entry_grads(int64_t n, const int32_t* gaussian_offsets, const T* entry_grads, T* v_splats) {
#pragma omp parallel for schedule(static) if (n >= kParallelMinSplats)
  for (int64_t i = 0; i < n; ++i) {
    T sum[kSplatGradFields] = {};
    for (int32_t j = gaussian_offsets[i]; j < gaussian_offsets[i + 1]; ++j) {
      const T* g = entry_grads + int64_t(j) * kSplatGradFields;
      for (int k = 0; k < kSplatGradFields; ++k) sum[k] += g[k];
    }
    std::copy(sum, sum + kSplatGradFields, v_splats + i * kSplatGradFields);
  }
}

void exp2_for_test(const float* x, float* y, int n) {
  switch (active_simd_level()) {
    case SimdLevel::avx512: avx512::exp2_floats(x, y, n); break;
    case SimdLevel::avx2: avx2::exp2_floats(x, y, n); break;
    default: generic::exp2_floats(x, y, n);
  }
}

template void composite_fwd<float>(const RasterFrame&, const CompositeInputs<float>&, float*, float*, float*, float*,
                                   int32_t*, int64_t*);
template void composite_fwd<double>(const RasterFrame&, const CompositeInputs<double>&, double*, double*, double*,
                                    double*, int32_t*, int64_t*);
template void composite_bwd<float>(const RasterFrame&, const CompositeInputs<float>&, const float*, const int32_t*,
                                   const float*, const float*, const float*, float*);
template void composite_bwd<double>(const RasterFrame&, const CompositeInputs<double>&, const double*,
                                    const int32_t*, const double*, const double*, const double*, double*);
template void reduce_entry_grads<float>(int64_t, const int32_t*, const float*, float*);
template void reduce_entry_grads<double>(int64_t, const int32_t*, const double*, double*);

}  // namespace handscs
