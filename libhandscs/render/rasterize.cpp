// Autograd glue of the splat rasterizer (checks, saved state, gradient slots) and the public free function.
// Forward: project -> bin into tiles -> composite. Saved for backward: the inputs, the splat records and tile lists
// (O(N + entries)), and per pixel only T_final and the last contributor; everything else is recomputed.
#include "render/rasterize.h"

#include <torch/csrc/autograd/custom_function.h>

#include "render/binning.h"
#include "render/composite.h"
#include "render/projection.h"
#include "render/raster_frame.h"

namespace handscs {

namespace {

using torch::autograd::AutogradContext;
using torch::autograd::variable_list;

// Gradient slots of RasterizeFunction::forward's arguments (after the context).
enum Slot { kMeans, kCovariances, kColors, kOpacities, kProbe, kCameraSlot, kSettingsSlot, kNumSlots };

// Indices of the tensors saved on the context.
enum Saved {
  kSavedMeans,
  kSavedCovariances,
  kSavedColors,
  kSavedSplats,
  kSavedRects,
  kSavedRadii,
  kSavedTileOffsets,
  kSavedTileGaussians,
  kSavedGaussianOffsets,
  kSavedEntrySlots,
  kSavedTFinal,
  kSavedLast,
  kNumSaved
};

torch::Tensor to_tensor(const std::vector<int32_t>& v) {
  auto t = torch::empty({int64_t(v.size())}, torch::kInt32);
  std::copy(v.begin(), v.end(), t.data_ptr<int32_t>());
  return t;
}

template <class T>
const T* ptr_or_null(const torch::Tensor& t) {
  return t.defined() && t.numel() > 0 ? t.data_ptr<T>() : nullptr;
}

struct RasterizeFunction : public torch::autograd::Function<RasterizeFunction> {
  static variable_list forward(AutogradContext* ctx, const torch::Tensor& means, const torch::Tensor& covariances,
                               const torch::Tensor& colors, const torch::Tensor& opacities,
                               const torch::Tensor& probe, const Camera& camera, const RasterSettings& settings) {
    const RasterFrame frame = make_raster_frame(camera, settings);
    const int64_t n = means.size(0);
    const auto fopts = means.options();
    auto splats = torch::zeros({n, kSplatFields}, fopts);
    auto rects = torch::empty({n, kRectFields}, torch::kInt32);
    auto radii = torch::empty({n}, torch::kInt32);
    auto rgb = torch::empty({frame.height, frame.width, 3}, fopts);
    auto alpha = torch::empty({frame.height, frame.width}, fopts);
    auto depth = settings.compute_depth ? torch::empty({frame.height, frame.width}, fopts) : torch::empty({0}, fopts);
    auto t_final = torch::empty({frame.height, frame.width}, fopts);
    auto last = torch::empty({frame.height, frame.width}, torch::kInt32);
    TileBins bins;
    AT_DISPATCH_FLOATING_TYPES(means.scalar_type(), "rasterize_gaussians", [&] {
      project_fwd<scalar_t>(frame, n, means.data_ptr<scalar_t>(), covariances.data_ptr<scalar_t>(),
                            colors.data_ptr<scalar_t>(), opacities.data_ptr<scalar_t>(),
                            probe.dim() == 2 ? ptr_or_null<scalar_t>(probe) : nullptr,
                            splats.data_ptr<scalar_t>(), rects.data_ptr<int32_t>(), radii.data_ptr<int32_t>());
      const bool ok = bin_splats<scalar_t>(frame, n, splats.data_ptr<scalar_t>(), rects.data_ptr<int32_t>(), bins);
      TORCH_CHECK(ok, "rasterize_gaussians: more than 2^31 (tile, Gaussian) pairs; the Gaussians are too large");
      CompositeInputs<scalar_t> in{splats.data_ptr<scalar_t>(), rects.data_ptr<int32_t>(), bins.tile_offsets.data(),
                                   bins.tile_gaussians.data()};
      composite_fwd<scalar_t>(frame, in, rgb.data_ptr<scalar_t>(), alpha.data_ptr<scalar_t>(),
                              settings.compute_depth ? depth.data_ptr<scalar_t>() : nullptr,
                              t_final.data_ptr<scalar_t>(), last.data_ptr<int32_t>());
    });
    std::vector<torch::Tensor> saved(kNumSaved);
    saved[kSavedMeans] = means;
    saved[kSavedCovariances] = covariances;
    saved[kSavedColors] = colors;
    saved[kSavedSplats] = splats;
    saved[kSavedRects] = rects;
    saved[kSavedRadii] = radii;
    saved[kSavedTileOffsets] = to_tensor(bins.tile_offsets);
    saved[kSavedTileGaussians] = to_tensor(bins.tile_gaussians);
    saved[kSavedGaussianOffsets] = to_tensor(bins.gaussian_offsets);
    saved[kSavedEntrySlots] = to_tensor(bins.entry_slots);
    saved[kSavedTFinal] = t_final;
    saved[kSavedLast] = last;
    ctx->save_for_backward(saved);
    ctx->saved_data["has_probe"] = probe.dim() == 2;
    ctx->saved_data["camera_K"] = std::vector<double>(camera.K.begin(), camera.K.end());
    ctx->saved_data["camera_R"] = std::vector<double>(camera.R.begin(), camera.R.end());
    ctx->saved_data["camera_t"] = std::vector<double>(camera.t.begin(), camera.t.end());
    ctx->saved_data["camera_size"] = std::vector<int64_t>{camera.width, camera.height};
    ctx->saved_data["camera_clip"] = std::vector<double>{camera.near_plane, camera.far_plane};
    ctx->saved_data["background"] = std::vector<double>(settings.background.begin(), settings.background.end());
    ctx->saved_data["roi"] = std::vector<int64_t>{settings.roi.x0, settings.roi.y0, settings.roi.x1, settings.roi.y1};
    ctx->saved_data["depth"] = settings.compute_depth;
    ctx->mark_non_differentiable({radii});
    if (!settings.compute_depth) ctx->mark_non_differentiable({depth});
    return {rgb, alpha, depth, radii};
  }

  static variable_list backward(AutogradContext* ctx, variable_list grads) {
    const auto saved = ctx->get_saved_variables();
    Camera camera;
    RasterSettings settings;
    const auto K = ctx->saved_data["camera_K"].toDoubleVector();
    const auto R = ctx->saved_data["camera_R"].toDoubleVector();
    const auto t = ctx->saved_data["camera_t"].toDoubleVector();
    const auto size = ctx->saved_data["camera_size"].toIntVector();
    const auto clip = ctx->saved_data["camera_clip"].toDoubleVector();
    const auto bg = ctx->saved_data["background"].toDoubleVector();
    const auto roi = ctx->saved_data["roi"].toIntVector();
    std::copy(K.begin(), K.end(), camera.K.begin());
    std::copy(R.begin(), R.end(), camera.R.begin());
    std::copy(t.begin(), t.end(), camera.t.begin());
    camera.width = int(size[0]);
    camera.height = int(size[1]);
    camera.near_plane = clip[0];
    camera.far_plane = clip[1];
    for (int c = 0; c < 3; ++c) settings.background[c] = float(bg[c]);
    settings.roi = PixelRect{int(roi[0]), int(roi[1]), int(roi[2]), int(roi[3])};
    const bool with_depth = ctx->saved_data["depth"].toBool();
    settings.compute_depth = with_depth;
    const RasterFrame frame = make_raster_frame(camera, settings);

    const torch::Tensor& means = saved[kSavedMeans];
    const int64_t n = means.size(0);
    const auto fopts = means.options();
    auto grad_or_empty = [&](int k) {
      if (k >= int(grads.size()) || !grads[k].defined()) return torch::Tensor();
      return grads[k].to(means.scalar_type()).contiguous();
    };
    const torch::Tensor v_rgb = grad_or_empty(0);
    const torch::Tensor v_alpha = grad_or_empty(1);
    const torch::Tensor v_depth = with_depth ? grad_or_empty(2) : torch::Tensor();
    const int64_t entries = saved[kSavedTileGaussians].numel();
    auto entry_grads = torch::empty({entries, kSplatGradFields}, fopts);
    auto v_splats = torch::empty({n, kSplatGradFields}, fopts);
    auto v_means = torch::empty({n, 3}, fopts);
    auto v_covs = torch::empty({n, 6}, fopts);
    auto v_colors = torch::empty({n, 3}, fopts);
    auto v_opacities = torch::empty({n}, fopts);
    const bool has_probe = ctx->saved_data["has_probe"].toBool();
    auto v_probe = has_probe ? torch::empty({n, 2}, fopts) : torch::Tensor();
    AT_DISPATCH_FLOATING_TYPES(means.scalar_type(), "rasterize_gaussians_backward", [&] {
      CompositeInputs<scalar_t> in{saved[kSavedSplats].data_ptr<scalar_t>(), saved[kSavedRects].data_ptr<int32_t>(),
                                   saved[kSavedTileOffsets].data_ptr<int32_t>(),
                                   saved[kSavedTileGaussians].data_ptr<int32_t>(),
                                   saved[kSavedEntrySlots].data_ptr<int32_t>()};
      composite_bwd<scalar_t>(frame, in, saved[kSavedTFinal].data_ptr<scalar_t>(),
                              saved[kSavedLast].data_ptr<int32_t>(), ptr_or_null<scalar_t>(v_rgb),
                              ptr_or_null<scalar_t>(v_alpha), ptr_or_null<scalar_t>(v_depth),
                              entry_grads.data_ptr<scalar_t>());
      reduce_entry_grads<scalar_t>(n, saved[kSavedGaussianOffsets].data_ptr<int32_t>(),
                                   entry_grads.data_ptr<scalar_t>(), v_splats.data_ptr<scalar_t>());
      project_bwd<scalar_t>(frame, n, means.data_ptr<scalar_t>(), saved[kSavedCovariances].data_ptr<scalar_t>(),
                            saved[kSavedColors].data_ptr<scalar_t>(), saved[kSavedRadii].data_ptr<int32_t>(),
                            v_splats.data_ptr<scalar_t>(), v_means.data_ptr<scalar_t>(),
                            v_covs.data_ptr<scalar_t>(), v_colors.data_ptr<scalar_t>(),
                            v_opacities.data_ptr<scalar_t>(), has_probe ? v_probe.data_ptr<scalar_t>() : nullptr);
    });
    variable_list out(kNumSlots);
    out[kMeans] = v_means;
    out[kCovariances] = v_covs;
    out[kColors] = v_colors;
    out[kOpacities] = v_opacities;
    out[kProbe] = v_probe;
    return out;
  }
};

void check_inputs(const torch::Tensor& means, const torch::Tensor& covariances, const torch::Tensor& colors,
                  const torch::Tensor& opacities, const torch::Tensor& probe) {
  TORCH_CHECK(means.defined() && means.dim() == 2 && means.size(1) == 3,
              "rasterize_gaussians: means must be [N, 3], got ", means.defined() ? means.sizes() : c10::IntArrayRef{});
  const int64_t n = means.size(0);
  TORCH_CHECK(means.scalar_type() == torch::kFloat32 || means.scalar_type() == torch::kFloat64,
              "rasterize_gaussians: means must be float32 or float64, got ", means.scalar_type());
  TORCH_CHECK(means.device().is_cpu(), "rasterize_gaussians: tensors must be on the CPU, got ", means.device());
  auto check = [&](const torch::Tensor& t, const char* name, std::vector<int64_t> shape) {
    TORCH_CHECK(t.defined() && t.sizes() == c10::IntArrayRef(shape), "rasterize_gaussians: ", name, " must be ",
                c10::IntArrayRef(shape), ", got ", t.defined() ? t.sizes() : c10::IntArrayRef{});
    TORCH_CHECK(t.scalar_type() == means.scalar_type(), "rasterize_gaussians: ", name, " must have the dtype of means (",
                means.scalar_type(), "), got ", t.scalar_type());
    TORCH_CHECK(t.device().is_cpu(), "rasterize_gaussians: ", name, " must be on the CPU, got ", t.device());
  };
  check(covariances, "covariances", {n, 6});
  check(colors, "colors", {n, 3});
  TORCH_CHECK(opacities.defined() && (opacities.sizes() == c10::IntArrayRef({n}) ||
                                      opacities.sizes() == c10::IntArrayRef({n, 1})),
              "rasterize_gaussians: opacities must be [", n, "] or [", n, ", 1], got ",
              opacities.defined() ? opacities.sizes() : c10::IntArrayRef{});
  check(opacities.reshape({n}), "opacities", {n});
  if (probe.defined()) check(probe, "means2d_probe", {n, 2});
}

}  // namespace

RasterOutput rasterize_gaussians(const torch::Tensor& means, const torch::Tensor& covariances,
                                 const torch::Tensor& colors, const torch::Tensor& opacities, const Camera& camera,
                                 const RasterSettings& settings, const torch::Tensor& means2d_probe) {
  check_inputs(means, covariances, colors, opacities, means2d_probe);
  const int64_t n = means.size(0);
  auto outputs = RasterizeFunction::apply(
      means.contiguous(), covariances.contiguous(), colors.contiguous(), opacities.reshape({n}).contiguous(),
      // LibTorch 1.13 custom functions reject undefined inputs: "no probe" is an empty 1-D tensor.
      means2d_probe.defined() ? means2d_probe.contiguous() : torch::empty({0}, means.options()), camera, settings);
  RasterOutput out;
  out.rgb = outputs[0];
  out.alpha = outputs[1];
  if (settings.compute_depth) {
    // Expected depth D / alpha. A pixel with any contribution has alpha >= 1/255, so the floor only turns 0/0
    // into 0 where nothing was drawn (and keeps the gradient finite there).
    out.depth = outputs[2] / outputs[1].clamp_min(0.5 * kAlphaSkip);
  }
  out.radii = outputs[3];
  return out;
}

}  // namespace handscs
