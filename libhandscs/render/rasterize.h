// Differentiable CPU splat rasterizer (3D Gaussian Splatting, EWA projection, front-to-back alpha blending).
//   C(p) = sum_i clamp(c_i, 0, 1) alpha_i(p) T_i(p) + T_final(p) bg,  T_i = prod_{j<i} (1 - alpha_j),
//   alpha_i(p) = min(0.99, o_i exp(-0.5 d^T Sigma2D_i^-1 d)),  d = p - mu2D_i,  Sigma2D = J W Sigma W^T J^T + 0.3 I.
//
// Conventions (see core/camera.h): OpenCV pinhole camera; pixel (i, j) is sampled at its centre (i + 0.5, j + 0.5),
// so a Gaussian projected to u = 10.5 is centred on pixel column 10. Gaussians are composited in increasing camera
// depth (ties: lower index first). Per pixel: alpha < 1/255 is skipped, and blending stops before T would drop
// below 1e-4 (the Gaussian that would cross it is not blended). The 2D mean is the projection of the 3D mean (plus
// means2d_probe when given).
//
// Culled Gaussians (radii 0, exactly zero gradients): any non-finite entry in its mean, covariance, colour or
// opacity; camera depth not in (near, far]; opacity below 1/255 (cannot reach a visible alpha); a projected
// covariance that is not positive definite; no pixel of the rendered region inside its extent. The extent is
// opacity-aware: the ellipse where o G >= 1/255, i.e. d^T Sigma2D^-1 d <= 2 ln(255 o).
//
// Gradients: exact for the function above, with these choices at non-smooth points:
//   - colours: the gradient of clamp(c, 0, 1) is 1 for 0 <= c <= 1 and 0 outside (as torch::clamp), so a colour
//     outside [0, 1] receives no gradient from the image (keep colours in range with a sigmoid or a regulariser);
//   - alpha cap: no gradient to opacity or geometry where o G > 0.99;
//   - the x/z, y/z clamp in the EWA Jacobian (to 1.3x the field of view) sends the Jacobian's gradient to z only;
//   - symmetric matrices (the 6 covariance entries xx, xy, xz, yy, yz, zz) are treated as 6 independent parameters:
//     the gradient of an off-diagonal entry is dL/dSigma_xy + dL/dSigma_yx (what finite differences of the 6-vector
//     give; tests/render check it).
// Not twice differentiable (the backward pass is a hand-written kernel).
//
// Execution: OpenMP over 16x16 tiles with the thread count of set_threads (core/threads.h); results are bitwise
// identical for any thread count. The projection runs in double whatever the dtype. The tile kernels use AVX-512,
// AVX2+FMA or baseline x86-64 code, chosen at run time (core/simd_level.h); in float32, o G is evaluated as one
// exp2 with a 2-ulp polynomial. Cost is proportional to the visible work: culled Gaussians, empty tiles, pixels
// outside the ROI and pixels past the transmittance stop cost (next to) nothing.
#pragma once

#include <array>

#include <torch/types.h>

#include "core/camera.h"

namespace handscs {

struct RasterSettings {
  std::array<float, 3> background{0, 0, 0};  // RGB composited behind the Gaussians (T_final * bg)
  PixelRect roi;               // empty = whole image; otherwise outputs are ROI-sized crops of the full image
  bool compute_depth = false;  // also return the expected camera depth per pixel
};

struct RasterOutput {
  torch::Tensor rgb;    // [H, W, 3] (H, W = image or ROI size)
  torch::Tensor alpha;  // [H, W] 1 - T_final
  torch::Tensor depth;  // [H, W] sum_i z_i alpha_i T_i / alpha (0 where alpha = 0), or undefined
  torch::Tensor radii;  // [N] int32 pixel radius of the extent, 0 for culled Gaussians (non-differentiable)
};

// Differentiable in means, covariances, colors, opacities and means2d_probe (float32 or float64, all one dtype,
// CPU). covariances: upper triangle (xx, xy, xz, yy, yz, zz) of the world-space 3D covariance.
// means2d_probe: optional [N, 2] tensor (zeros, requires_grad) added to the projected 2D means; its .grad receives
// dL/d(projected 2D mean in pixels), whose norm drives 3DGS densification.
RasterOutput rasterize_gaussians(const torch::Tensor& means,        // [N, 3] world
                                 const torch::Tensor& covariances,  // [N, 6]
                                 const torch::Tensor& colors,       // [N, 3] RGB (clamped to [0, 1])
                                 const torch::Tensor& opacities,    // [N] or [N, 1] in (0, 1]
                                 const Camera& camera, const RasterSettings& settings,
                                 const torch::Tensor& means2d_probe = {});  // [N, 2] or undefined

// Sigma = R(q) diag(s)^2 R(q)^T as the upper triangle (xx, xy, xz, yy, yz, zz), via differentiable torch ops.
// q = (w, x, y, z) is normalised inside (|q| floored at 1e-12 so q = 0 gives a finite result).
torch::Tensor covariance_from_scale_rotation(const torch::Tensor& scales,  // [N, 3] standard deviations (not log)
                                             const torch::Tensor& quats);  // [N, 4] w, x, y, z

}  // namespace handscs
