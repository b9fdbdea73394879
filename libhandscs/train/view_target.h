// What a training view is compared against: its ROI crop, scaled by train.resolution_scale, with
// the hand composited on the view's background (white, black, or random per view).
#pragma once

#include <array>
#include <cstdint>

#include <torch/types.h>

#include "core/camera.h"
#include "data/capture.h"
#include "run/train_config.h"

namespace handscs {

struct ViewTarget {
  Camera camera;         // of the scaled crop
  torch::Tensor target;  // [h, w, 3] the crop composited on `background`
  torch::Tensor mask;    // [h, w] in [0, 1]
  std::array<float, 3> background{};
};

// The background of view `view_index` of a run (random: a function of seed and index alone, so a
// resumed run draws the same).
std::array<float, 3> training_background(TrainConfig::Background kind, int64_t seed,
                                         int64_t view_index);

// sample (of `frame`) scaled by `scale` (area averaging) and composited on `background`. Throws
// Error, naming the image, when the scaled crop is smaller than min_side (training_checks.h).
ViewTarget make_view_target(const FrameSample& sample, const FrameInfo& frame, double scale,
                            int64_t min_side, const std::array<float, 3>& background);

}  // namespace handscs
