// Which Gaussians a view would see, without rasterising: the pixel radius the rasterizer's
// projection gives each one (0 = culled: behind the camera, outside the image, opacity below 1/255,
// non-finite). train.cull uses it to count the back-facing Gaussians it skipped as seen by the view
// for densification, as the exact render would have counted them.
#pragma once

#include <torch/types.h>

#include "render/rasterize.h"

namespace handscs {

// means [N, 3], covariances [N, 6] (upper triangle), opacities [N]; any float dtype, no gradient.
// Returns [N] int32, equal to rasterize_gaussians(...).radii for the same inputs and no probe.
torch::Tensor projected_radii(const torch::Tensor& means, const torch::Tensor& covariances,
                              const torch::Tensor& opacities, const Camera& camera,
                              const RasterSettings& settings);

}  // namespace handscs
