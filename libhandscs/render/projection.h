// EWA projection of 3D Gaussians to screen-space splats, and its hand-written backward (raw kernels).
//   p = R m + t,  mu2D = (fx x/z + cx, fy y/z + cy) + probe,  Sigma2D = (J R) Sigma (J R)^T + 0.3 I,
//   J = [[fx/z, 0, -fx u/z], [0, fy/z, -fy v/z]] with u = clamp(x/z), v = clamp(y/z),  conic = Sigma2D^-1.
#pragma once

#include <cstdint>

#include "render/raster_frame.h"

namespace handscs {

// One splat record per Gaussian (T[kSplatFields]); gradient records are T[kSplatGradFields] with the same slots.
enum SplatField {
  kSplatX,        // 2D mean, region-local pixels (pixel i is sampled at i + 0.5)
  kSplatY,
  kSplatConicA,   // conic = [[a, b], [b, c]] (gradient slot kSplatConicB: d/db with b in both off-diagonals)
  kSplatConicB,
  kSplatConicC,
  kSplatOpacity,
  kSplatRed,      // colour clamped to [0, 1]
  kSplatGreen,
  kSplatBlue,
  kSplatDepth,    // camera z
  kSplatGradFields,
  kSplatLog2Opacity = kSplatGradFields,  // log2(opacity): the kernels evaluate o G as one exp2
  kSplatFields
};

// Pixel bounding box of the opacity-aware extent, region-local, clipped to the region: [x0, x1) x [y0, y1).
enum RectField { kRectX0, kRectX1, kRectY0, kRectY1, kRectFields };

// Projects n Gaussians. Culled ones get radius 0 and an empty rect (their splat record is left zero).
// Never throws; runs OpenMP-parallel over Gaussians. The arithmetic is in double whatever T is.
template <class T>
void project_fwd(const RasterFrame& frame, int64_t n,
                 const T* means,      // [n, 3]
                 const T* covs,       // [n, 6] upper triangle xx xy xz yy yz zz
                 const T* colors,     // [n, 3]
                 const T* opacities,  // [n]
                 const T* probe,      // [n, 2] or nullptr
                 T* splats,           // [n, kSplatFields] out
                 int32_t* rects,      // [n, kRectFields] out
                 int32_t* radii);     // [n] out

// Chains the splat-record gradients back to the inputs. Gaussians with radius 0 get exactly zero gradients.
template <class T>
void project_bwd(const RasterFrame& frame, int64_t n, const T* means, const T* covs, const T* colors,
                 const int32_t* radii,   // [n] from project_fwd
                 const T* v_splats,      // [n, kSplatGradFields]
                 T* v_means,             // [n, 3] out
                 T* v_covs,              // [n, 6] out
                 T* v_colors,            // [n, 3] out
                 T* v_opacities,         // [n] out
                 T* v_probe);            // [n, 2] out or nullptr

}  // namespace handscs
