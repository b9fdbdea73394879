#include "train/train_memory.h"

#include <algorithm>
#include <cmath>

#include <spdlog/spdlog.h>

#include "core/error.h"
#include "core/text.h"
#include "data/capture.h"
#include "data/mesh_mask.h"
#include "data/roi.h"

namespace handscs {

namespace {

// The constants, fitted to peak RSS of handscs-train on the tiny and demo captures (docs/SAFETY.md,
// "A training run's memory"), rounded up where the fit fell short of a run:
// - the process before training (LibTorch and OpenCV mapped, the capture's tables, the rig): 225 MB,
//   from runs at 10,000 and 40,000 Gaussians extrapolated to none;
constexpr double kProcessBytes = 225e6;
// - a Gaussian: 2.9 KB (parameters, Adam's two moments, the gradients, the checkpoint written and
//   the state kept for a rollback) and 58 bytes per unit of model.decoder_hidden (the decoders'
//   saved activations: 397 -> 554 MB for 256 -> 512 units at 10,000 Gaussians);
constexpr double kGaussianBytes = 2.9e3, kGaussianHiddenBytes = 58;
// - and 1.5 KB a Gaussian for each entry of a batch after the first (its inter-pose chains and
//   descriptors: 397 -> 444 MB for train.batch_size 1 -> 4 at 10,000 Gaussians);
constexpr double kGaussianEntryBytes = 1.5e3;
// - a cached crop pixel: RGB and mask, one byte each (data/crop_cache.h);
constexpr double kCachedPixelBytes = 4;
// - a rendered pixel of a training view: the rasteriser's per-pixel state, the losses' planes
//   (SSIM's windows among them) and their gradients, 400 bytes; of the validation's whole image,
//   rendered without gradients, 80 bytes (a 16x larger crop and image added 50 MB: either fits);
constexpr double kViewPixelBytes = 400, kImagePixelBytes = 80;
// - LPIPS: AlexNet's weights and its activations per pixel of a view, forward and backward (14 and
//   72 MB more at crops of 14,000 and 140,000 pixels).
constexpr double kLpipsBytes = 8e6, kLpipsPixelBytes = 460;

int64_t bytes(double b) { return static_cast<int64_t>(std::ceil(b)); }

}  // namespace

int64_t reachable_gaussians(const TrainConfig& train, int64_t initial) {
  const DensifyConfig& d = train.densify;
  if (!d.enabled || initial >= d.max_gaussians) return initial;
  const int64_t last = std::min(d.stop, train.iterations);
  const int64_t first = std::max<int64_t>(d.start, 1);
  if (last < first) return initial;
  // Densification steps: multiples of the interval in [first, last].
  const int64_t rounds = last / d.interval - (first - 1) / d.interval;
  int64_t count = initial;
  for (int64_t r = 0; r < rounds && count < d.max_gaussians; ++r) count *= 2;
  return std::min(count, d.max_gaussians);
}

TrainMemoryInputs train_memory_inputs(Capture& capture, int64_t initial_gaussians, int hands) {
  TrainMemoryInputs in;
  in.initial_gaussians = initial_gaussians;
  in.hands = hands;
  const int margin = capture.config().roi_margin;
  for (const FrameInfo& frame : capture.frames()) {
    const Camera& camera = frame.camera;
    in.largest_image = std::max<int64_t>(in.largest_image, int64_t{camera.width} * camera.height);
  }
  for (const FrameInfo& frame : capture.train()) {
    const Camera& camera = frame.camera;
    const std::vector<float>& vertices = capture.posed_vertices(frame.pose_index);
    const PixelRect bounds =
        projected_bounds(vertices.data(), static_cast<int64_t>(vertices.size() / 3), camera);
    // Nothing in view: the whole image, as the loader's ROI of an empty mask.
    const PixelRect rect = bounds.empty() ? PixelRect{0, 0, camera.width, camera.height}
                                          : grow_rect(bounds, margin, camera.width, camera.height);
    const int64_t pixels = std::max<int64_t>(0, int64_t{rect.x1 - rect.x0}) * std::max(0, rect.y1 - rect.y0);
    in.crop_pixels += pixels;
    in.largest_crop = std::max(in.largest_crop, pixels);
  }
  return in;
}

TrainMemoryEstimate estimate_train_memory(const RunConfig& config, const TrainMemoryInputs& in) {
  const TrainConfig& train = config.train;
  TrainMemoryEstimate e;
  spdlog::debug("memory estimate: {} crop pixels, the largest crop {}, the largest image {}, {} "
                "Gaussians a hand now, {} hands",
                in.crop_pixels, in.largest_crop, in.largest_image, in.initial_gaussians, in.hands);
  e.process = bytes(kProcessBytes);
  e.images = std::min<int64_t>(bytes(kCachedPixelBytes * static_cast<double>(in.crop_pixels)),
                               config.data.cache.budget_mb << 20);
  e.gaussian_count = reachable_gaussians(train, in.initial_gaussians) * in.hands;
  e.gaussians = bytes(static_cast<double>(e.gaussian_count) *
                      (kGaussianBytes + kGaussianHiddenBytes * config.model.decoder_hidden +
                       kGaussianEntryBytes * static_cast<double>(train.batch_size - 1)));
  // A step renders its entries one after another, each with train.views_per_pose views; the
  // validation renders one whole image.
  const double scale2 = train.resolution_scale * train.resolution_scale;
  const double view_pixels = static_cast<double>(in.largest_crop) * scale2 * train.views_per_pose;
  e.pixels = bytes(std::max(kViewPixelBytes * view_pixels,
                            kImagePixelBytes * static_cast<double>(in.largest_image)));
  if (train.loss.lpips > 0 && !config.eval.lpips.weights.empty())
    e.lpips = bytes(kLpipsBytes + kLpipsPixelBytes * view_pixels);
  return e;
}

std::string train_memory_text(const TrainMemoryEstimate& e) {
  std::string text = "about " + bytes_text(static_cast<double>(e.total())) + " at the peak (" +
                     std::to_string(e.gaussian_count) + " Gaussians: " +
                     bytes_text(static_cast<double>(e.gaussians)) +
                     ", cached images: " + bytes_text(static_cast<double>(e.images)) +
                     ", rendered pixels: " + bytes_text(static_cast<double>(e.pixels));
  if (e.lpips > 0) text += ", LPIPS: " + bytes_text(static_cast<double>(e.lpips));
  return text + ", the process: " + bytes_text(static_cast<double>(e.process)) + ")";
}

void check_train_memory(const TrainMemoryEstimate& e, int64_t available_bytes) {
  if (available_bytes < 0 || e.total() <= available_bytes) return;
  throw Error("train: this run needs " + train_memory_text(e) + ", more than the " +
              bytes_text(static_cast<double>(available_bytes)) +
              " this machine has available. Fewer Gaussians (train.densify.max_gaussians), smaller "
              "decoders (model.decoder_hidden), a smaller image cache (data.cache.budget_mb) or "
              "smaller images (train.resolution_scale, train.views_per_pose) need less");
}

}  // namespace handscs
