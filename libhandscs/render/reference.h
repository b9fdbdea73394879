// Reference splat rasterizer in plain LibTorch ops (dense: every pixel against every Gaussian, O(H W N) memory),
// differentiable by autograd. Same function, constants and culling rules as rasterize_gaussians (render/rasterize.h)
// but no tiles, no extents, no early exit and no hand-written backward: the oracle for tests. Small scenes only.
#pragma once

#include <torch/types.h>

#include "render/rasterize.h"

namespace handscs {

// Same contract as rasterize_gaussians; radii are not computed (undefined).
RasterOutput rasterize_gaussians_reference(const torch::Tensor& means,        // [N, 3]
                                           const torch::Tensor& covariances,  // [N, 6]
                                           const torch::Tensor& colors,       // [N, 3]
                                           const torch::Tensor& opacities,    // [N] or [N, 1]
                                           const Camera& camera, const RasterSettings& settings,
                                           const torch::Tensor& means2d_probe = {});  // [N, 2] or undefined

}  // namespace handscs
