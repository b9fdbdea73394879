// train.densify as a training component: a probe per view that takes the gradient of the
// Gaussians' projected centres, each entry's statistics (summed over the ranks as named slots of
// the step's all-reduce), and the densification itself, decided on rank 0 when it is due.
#pragma once

#include <functional>

#include "train/densify.h"
#include "train/training_component.h"

namespace handscs {

class DensifyComponent : public TrainingComponent {
 public:
  // gaussian_count: the hand's Gaussians now (the size of a step's statistics when its entries did
  // not show the hand: zeros on the all-reduce).
  DensifyComponent(const DensifyConfig& config, std::function<int64_t()> gaussian_count);

  void before_render(const EntryContext& entry, ViewRender& view) override;
  void after_backward(const EntryContext& entry) override;
  void contribute(ReduceSlots& slots) const override;
  void receive(const ReduceSlots& slots, double inverse_ranks) override;
  void after_step(const StepContext& step) override;
  void after_skipped_step() override { step_ = {}; }
  bool may_change_gaussians(int64_t iteration) const override { return densifier_.due(iteration); }
  void save(Checkpoint& checkpoint, int64_t iteration) const override;
  void load(const Checkpoint& checkpoint, const LoadContext& context) override;

 private:
  Densifier densifier_;
  std::function<int64_t()> gaussian_count_;
  Densifier::ViewStatistics step_;  // this step's, summed over its entries (then its ranks)
};

}  // namespace handscs
