// train.loss.lpips_every as a training component: the LPIPS term is taken on one step in every
// lpips_every (the others skip the network's forward and backward).
#pragma once

#include "train/training_component.h"

namespace handscs {

class LpipsSchedule : public TrainingComponent {
 public:
  explicit LpipsSchedule(int64_t every) : every_(every) {}

  void prepare_loss(EntryContext& entry, LossInputs& inputs) override {
    inputs.lpips_step = (entry.iteration + 1) % every_ == 0;
  }

 private:
  int64_t every_;
};

}  // namespace handscs
