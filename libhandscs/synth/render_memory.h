// The memory handscs-synth's rendering needs, estimated from its settings before anything renders,
// and the check that refuses a capture this machine cannot hold: at 8192 x 8192 pixels each image
// rendered at once needs several GB.
// Per image: 30 bytes a pixel (the noisy background, 12, and the view's planes, 18: synth/render.h)
// and 20 bytes a sub-sample of the hand's rectangle (the rasteriser's triangle id, depth and
// barycentrics, data/mesh_raster.h), supersample^2 sub-samples a pixel, the rectangle taken at the
// largest any pose and camera gives; EasyMocap's lens distortion then needs 61 bytes a pixel.
// Measured on one 2048 x 2048 image: supersample 1, 3 and 5 took 138, 263 and 512 MB above the
// process's own 194 MB, 29 bytes a pixel and a rest growing with supersample^2 (1 : 9 : 25).
#pragma once

#include <cstdint>

#include "synth/config.h"

namespace handscs {

// Bytes the rendering holds at its peak with `threads` threads, each rendering one image at a
// time (no more images at once than the capture has).
int64_t synth_render_bytes(const SynthConfig& config, int threads);

// Throws Error when synth_render_bytes exceeds `available_bytes` (core/available_memory.h; < 0:
// not known, nothing refused), naming the estimate, the memory available and the keys that
// lower it.
void check_synth_memory(const SynthConfig& config, int threads, int64_t available_bytes);

}  // namespace handscs
