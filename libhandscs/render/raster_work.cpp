#include "render/raster_work.h"

#include <ATen/Dispatch.h>
#include <torch/types.h>

#include "render/binning.h"
#include "render/composite.h"
#include "render/projection.h"
#include "render/raster_frame.h"

namespace handscs {

RasterWork measure_raster_work(const torch::Tensor& means, const torch::Tensor& covariances,
                               const torch::Tensor& colors, const torch::Tensor& opacities, const Camera& camera,
                               const RasterSettings& settings) {
  const int64_t n = means.size(0);
  TORCH_CHECK(means.dim() == 2 && means.size(1) == 3 && covariances.sizes() == c10::IntArrayRef({n, 6}) &&
                  colors.sizes() == c10::IntArrayRef({n, 3}) && opacities.numel() == n,
              "measure_raster_work: expected means [N, 3], covariances [N, 6], colors [N, 3], opacities [N], got ",
              means.sizes(), ", ", covariances.sizes(), ", ", colors.sizes(), ", ", opacities.sizes());
  const RasterFrame frame = make_raster_frame(camera, settings);
  c10::InferenceMode guard;
  const auto m = means.contiguous(), c = covariances.contiguous().to(m.scalar_type());
  const auto col = colors.contiguous().to(m.scalar_type()), o = opacities.reshape({n}).contiguous().to(m.scalar_type());
  auto splats = torch::zeros({n, kSplatFields}, m.options());
  auto rects = torch::empty({n, kRectFields}, torch::kInt32);
  auto radii = torch::empty({n}, torch::kInt32);
  auto rgb = torch::empty({frame.height, frame.width, 3}, m.options());
  auto alpha = torch::empty({frame.height, frame.width}, m.options());
  auto t_final = torch::empty({frame.height, frame.width}, m.options());
  auto last = torch::empty({frame.height, frame.width}, torch::kInt32);
  RasterWork work;
  AT_DISPATCH_FLOATING_TYPES(m.scalar_type(), "measure_raster_work", [&] {
    project_fwd<scalar_t>(frame, n, m.data_ptr<scalar_t>(), c.data_ptr<scalar_t>(), col.data_ptr<scalar_t>(),
                          o.data_ptr<scalar_t>(), nullptr, splats.data_ptr<scalar_t>(), rects.data_ptr<int32_t>(),
                          radii.data_ptr<int32_t>());
    TileBins bins;
    TORCH_CHECK(bin_splats<scalar_t>(frame, n, splats.data_ptr<scalar_t>(), rects.data_ptr<int32_t>(), bins),
                "measure_raster_work: too many (tile, Gaussian) pairs");
    CompositeInputs<scalar_t> in{splats.data_ptr<scalar_t>(), rects.data_ptr<int32_t>(), bins.tile_offsets.data(),
                                 bins.tile_gaussians.data()};
    composite_fwd<scalar_t>(frame, in, rgb.data_ptr<scalar_t>(), alpha.data_ptr<scalar_t>(), nullptr,
                            t_final.data_ptr<scalar_t>(), last.data_ptr<int32_t>(), &work.contributing_pairs);
    work.tile_entries = bins.num_entries();
  });
  work.visible_gaussians = (radii > 0).sum().item<int64_t>();
  return work;
}

}  // namespace handscs
