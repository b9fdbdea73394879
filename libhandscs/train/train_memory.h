// The memory handscs-train needs at its peak, estimated before the first step from the settings
// and the capture, and the check that refuses a run this machine cannot hold (a run at the largest
// widths, or densification without bounds, would otherwise end hours later out of memory).
// The parts and their constants were measured with /usr/bin/time -v (docs/SAFETY.md, "A training
// run's memory"): peak RSS = process + images + gaussians + pixels + lpips.
#pragma once

#include <cstdint>
#include <string>

#include "run/run_config.h"

namespace handscs {

class Capture;

// What the estimate reads from the capture and the model.
struct TrainMemoryInputs {
  int64_t crop_pixels = 0;     // sum over training frames of their crop's pixels (full scale)
  int64_t largest_crop = 0;    // pixels of the largest training crop (full scale)
  int64_t largest_image = 0;   // pixels of the largest image (the validation renders one whole)
  int64_t initial_gaussians = 0;  // per hand, before densification
  int hands = 1;
};

// The estimate by part, in bytes.
struct TrainMemoryEstimate {
  int64_t process = 0;    // the process before training: LibTorch, the capture's tables, the rig
  int64_t images = 0;     // the decoded-crop cache: every training crop, at most data.cache.budget_mb
  int64_t gaussians = 0;  // parameters, Adam's moments, checkpoints and the decoders' activations
  int64_t pixels = 0;     // a step's views or the validation render, whichever is larger
  int64_t lpips = 0;      // LPIPS's network and its activations on a step's views
  int64_t gaussian_count = 0;  // the largest count densification can reach, every hand
  int64_t total() const { return process + images + gaussians + pixels + lpips; }
};

// The most Gaussians a hand can have: densification at most doubles the count each round
// (train.densify.start, interval, stop, iterations) and never passes train.densify.max_gaussians.
int64_t reachable_gaussians(const TrainConfig& train, int64_t initial);

// The inputs of the capture's training frames: each crop is the posed mesh's projected bounding
// box grown by data.roi_margin, as the crop of its mask is.
TrainMemoryInputs train_memory_inputs(Capture& capture, int64_t initial_gaussians, int hands);

TrainMemoryEstimate estimate_train_memory(const RunConfig& config, const TrainMemoryInputs& inputs);

// "about 1.2 GB at the peak (10000 Gaussians: 400 MB, images: 80 MB, ...)".
std::string train_memory_text(const TrainMemoryEstimate& estimate);

// Throws Error when the estimate exceeds `available_bytes` (core/available_memory.h; < 0: not
// known, nothing refused), naming both figures, the largest parts and the keys that lower them.
void check_train_memory(const TrainMemoryEstimate& estimate, int64_t available_bytes);

}  // namespace handscs
