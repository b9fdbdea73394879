// Where a run's hands stood: the pose, shape and place of each hand in its first training frame,
// stored in every checkpoint. A viewer without the run's capture (an avatar shared on its own) uses
// it to place both hands of a two-hand avatar beside each other, and to give either its captured
// shape. It is the object a POSES file holds for one frame (infer/pose_source.h).
#pragma once

#include <vector>

#include <nlohmann/json.hpp>

#include "data/capture.h"

namespace handscs {

// The checkpoint metadata key that holds it (absent from older checkpoints).
inline constexpr const char* kPlacementKey = "placement";

// {"pose": [48], "shape": [10], "trans": [3]}: one hand's parameters as a POSES file holds them.
nlohmann::json hand_params_to_json(const HandParams& hand);

// The placement of `train` (a capture's training frames, not empty): the first frame that holds
// every hand any of them holds, or the first frame when none holds all. A one-hand frame gives
// {"pose", "shape", "trans", "name"}, a two-hand one {"right": {...}, "left": {...}, "name"}; the
// name is the frame's image.
nlohmann::json training_placement(const std::vector<FrameInfo>& train);

}  // namespace handscs
