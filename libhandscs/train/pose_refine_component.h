// train.pose_refine as a training component: the entry's pose corrected before it is decoded,
// the correction's penalty and gradient, the updates of every rank's entries (data parallel:
// named slots of the step's all-reduce), one Adam step per updated pose, the diagnostics, the
// checkpoint section and the run's pose_refine.csv.
#pragma once

#include <memory>
#include <vector>

#include "train/pose_refine.h"
#include "train/training_component.h"

namespace handscs {

class PoseRefineComponent : public TrainingComponent {
 public:
  // entries_per_step: entries of a step over every rank (one update slot each).
  PoseRefineComponent(int64_t num_poses, const PoseRefineConfig& config, int64_t entries_per_step);

  void before_decode(EntryContext& entry) override;
  void add_penalties(const EntryContext& entry,
                     std::map<std::string, torch::Tensor>& penalties) override;
  void diagnostics(const EntryContext&, std::map<std::string, double>& values) override;
  void after_backward(const EntryContext& entry) override;
  void contribute(ReduceSlots& slots) const override;
  void receive(const ReduceSlots& slots, double inverse_ranks) override;
  bool finite() const override;
  void after_step(const StepContext&) override;
  void after_skipped_step() override { updates_.clear(); }
  void save(Checkpoint& checkpoint, int64_t iteration) const override;
  void load(const Checkpoint& checkpoint, const LoadContext& context) override;
  void finish(const std::string& run_dir) const override;

 private:
  // One pose-correction update of a step.
  struct Update {
    int64_t step_entry = 0;  // the step's entry, over every rank
    int64_t pose_index = 0;  // the training pose whose correction it updates
    torch::Tensor grad;      // [PoseCorrections::kWidth], scaled as the step's mean over entries
  };
  int64_t num_poses_;
  PoseRefineConfig config_;
  int64_t entries_per_step_;
  std::unique_ptr<PoseCorrections> corrections_;
  std::vector<torch::Tensor> deltas_;  // this rank's entries' corrections (undefined: not learned)
  std::vector<Update> updates_;        // of the step so far, in entry order
};

}  // namespace handscs
