#include "synth/render_memory.h"

#include <algorithm>

#include "core/error.h"
#include "core/text.h"

namespace handscs {

namespace {

// Bytes a pixel of every image (background and the view's planes), a rasterised sub-sample, and a
// pixel of EasyMocap's lens distortion (two double points, two float maps and the distorted image,
// beside the view's planes).
constexpr double kPixelBytes = 30, kSampleBytes = 20, kLensPixelBytes = 61;
// Largest extent of the rendered mesh, as the square root of its image rectangle's area in metres
// at the camera's distance: 0.176 m measured for the hand alone and 0.226 m with the forearm, over
// every image of the paper, demo and tiny presets; a few percent added for other seeds.
constexpr double kHandSpan = 0.19, kHandAndForearmSpan = 0.24;
// Portrait width the focal length is given at (SynthConfig::focal): it scales with the width.
constexpr double kFocalWidth = 334.0;

// Images rendered at once: one a thread, no more than the capture has.
int64_t images_at_once(const SynthConfig& config, int threads) {
  const int64_t images = static_cast<int64_t>(config.num_cameras) * config.num_frames;
  return std::max<int64_t>(1, std::min<int64_t>(threads, images));
}

}  // namespace

int64_t synth_render_bytes(const SynthConfig& config, int threads) {
  const double pixels = static_cast<double>(config.width) * config.height;
  // The hand's rectangle in pixels: its extent times the focal length over the distance.
  const double focal = config.focal * config.width / kFocalWidth;
  const double span = (config.effects.forearm ? kHandAndForearmSpan : kHandSpan) * focal /
                      config.camera_distance;
  const double rectangle = std::min(pixels, span * span);
  const double samples = rectangle * config.supersample * config.supersample;
  double image = kPixelBytes * pixels + kSampleBytes * samples;
  if (config.layout == CaptureConfig::Layout::easymocap)
    image = std::max(image, kLensPixelBytes * pixels);
  return static_cast<int64_t>(image) * images_at_once(config, threads);
}

void check_synth_memory(const SynthConfig& config, int threads, int64_t available_bytes) {
  const int64_t needed = synth_render_bytes(config, threads);
  if (available_bytes < 0 || needed <= available_bytes) return;
  throw Error("synth: rendering " + std::to_string(config.width) + " x " + std::to_string(config.height) +
              " images at supersample " + std::to_string(config.supersample) + " (" +
              std::to_string(images_at_once(config, threads)) + " at once: --threads) needs about " +
              bytes_text(needed) + ", more than the " + bytes_text(available_bytes) +
              " this machine has available; lower width and height, supersample or --threads");
}

}  // namespace handscs
