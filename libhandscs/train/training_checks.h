// Checks of a training run that need the capture: image sizes against the windows of the image
// losses (SSIM, LPIPS) at train.resolution_scale, and hand masks that are empty.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "data/capture.h"
#include "run/train_config.h"

namespace handscs {

class Lpips;

// Smallest image side the enabled image losses accept: the SSIM window when train.loss.ssim > 0,
// LPIPS's backbone minimum when `lpips` is given (1 when neither is on).
int64_t min_loss_image_side(const LossWeights& weights, const Lpips* lpips);

// Throws Error naming train.resolution_scale when the full image of some training frame, scaled,
// is smaller than min_side (crops are smaller still, so no step could compute the losses).
void check_training_image_sizes(const std::vector<FrameInfo>& train, double scale, int64_t min_side);

// "" when a width x height training crop (after scaling) is large enough, else the error text
// naming train.resolution_scale, the frame and the sizes.
std::string scaled_crop_problem(const FrameInfo& frame, int width, int height, double scale,
                                int64_t min_side);

// "" when a step's views (train.batch_size on each of `processes`) are no more than the capture's
// `training_views`, else a warning naming train.batch_size, the counts and what a step then costs
// (every view rendered several times a step: a 4096-view batch over 36 views took 107 s a step).
std::string batch_size_warning(int64_t batch_size, int64_t processes, int64_t training_views);

// data.hand both: "" when every hand is in some training frame, else a warning naming the hand
// no training frame has (its annotations absent or null) and the data.hand that trains the other
// alone. Such a hand's avatar would keep its initial state, its checkpoint and renders untrained.
std::string missing_hand_warning(const std::vector<FrameInfo>& train);

// Watches the masks of the first training steps: when every one of the first `steps` masks is
// empty the run supervises nothing (the loss is 0 and PSNR is perfect), so record() throws Error;
// later empty masks are warned about with their path (the first few), and counted.
class EmptyMaskWatch {
 public:
  explicit EmptyMaskWatch(int64_t steps) : steps_(steps) {}
  void record(const FrameInfo& frame, bool empty);
  int64_t empty_count() const { return empty_; }

 private:
  int64_t steps_;
  int64_t seen_ = 0;
  int64_t empty_ = 0;
  bool any_hand_ = false;
};

}  // namespace handscs
