// Which training frames each entry of a run renders: one frame of a per-epoch shuffle of the
// training frames (views_per_pose 1), else up to views_per_pose of the cameras, in a shuffled
// order, of one pose of a per-epoch shuffle of the training poses. Every order is a function of
// (seed, entry index) alone, so a resumed run, or the same step on another rank layout, sees the
// same frames.
#pragma once

#include <cstdint>
#include <vector>

#include "data/capture.h"

namespace handscs {

class EntryOrder {
 public:
  // frames: the capture's training frames (kept by reference: they outlive the order).
  EntryOrder(const std::vector<FrameInfo>& frames, int64_t views_per_pose, int64_t seed);

  // The frames of entry `entry_index` (= step x entries per step + its place in the step).
  std::vector<const FrameInfo*> frames_for(int64_t entry_index);

 private:
  const std::vector<FrameInfo>& frames_;
  int64_t views_per_pose_;
  int64_t seed_;
  // views_per_pose > 1: positions in frames_ of each training pose's frames, by pose index.
  std::vector<std::vector<int64_t>> poses_;
  std::vector<int64_t> order_;  // frame (or pose) permutation of the current epoch
  int64_t order_epoch_ = -1;
};

}  // namespace handscs
