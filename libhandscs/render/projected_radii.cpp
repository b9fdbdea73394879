#include "render/projected_radii.h"

#include <ATen/Dispatch.h>
#include <torch/types.h>

#include "render/projection.h"
#include "render/raster_frame.h"

namespace handscs {

torch::Tensor projected_radii(const torch::Tensor& means, const torch::Tensor& covariances,
                              const torch::Tensor& opacities, const Camera& camera,
                              const RasterSettings& settings) {
  const int64_t n = means.size(0);
  TORCH_CHECK(means.dim() == 2 && means.size(1) == 3 && covariances.sizes() == c10::IntArrayRef({n, 6}) &&
                  opacities.numel() == n,
              "projected_radii: expected means [N, 3], covariances [N, 6], opacities [N], got ",
              means.sizes(), ", ", covariances.sizes(), ", ", opacities.sizes());
  const RasterFrame frame = make_raster_frame(camera, settings);
  torch::NoGradGuard no_grad;
  const auto m = means.detach().contiguous();
  const auto c = covariances.detach().contiguous().to(m.scalar_type());
  const auto o = opacities.detach().reshape({n}).contiguous().to(m.scalar_type());
  const auto colors = torch::zeros({n, 3}, m.options());  // the radius does not depend on colour
  auto splats = torch::empty({n, kSplatFields}, m.options());
  auto rects = torch::empty({n, kRectFields}, torch::kInt32);
  auto radii = torch::empty({n}, torch::kInt32);
  AT_DISPATCH_FLOATING_TYPES(m.scalar_type(), "projected_radii", [&] {
    project_fwd<scalar_t>(frame, n, m.data_ptr<scalar_t>(), c.data_ptr<scalar_t>(), colors.data_ptr<scalar_t>(),
                          o.data_ptr<scalar_t>(), nullptr, splats.data_ptr<scalar_t>(), rects.data_ptr<int32_t>(),
                          radii.data_ptr<int32_t>());
  });
  return radii;
}

}  // namespace handscs
