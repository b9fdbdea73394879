// L_con (paper §3.3) as a training component: each entry of a step keeps an inter-pose chain (the
// descriptors, attributes and pose feature it decoded) and is paired with the same entry of the
// step before. The chains are dropped when densification changes the Gaussians' rows, saved in
// checkpoints by view, and (data parallel) gathered on rank 0 before each checkpoint, so that a
// resume or a rollback gives every rank its chains back.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "run/train_config.h"
#include "train/training_component.h"

namespace handscs {

class ConsistencyComponent : public TrainingComponent {
 public:
  // entries: this rank's entries per step; first_entry: this rank's first entry of a step.
  ConsistencyComponent(const ConsistencyConfig& config, bool flat_hand_mean, int64_t entries,
                       int64_t first_entry);

  void before_decode(EntryContext& entry) override { entry.need_descriptor = true; }
  void prepare_loss(EntryContext& entry, LossInputs& inputs) override;
  void after_step(const StepContext&) override { prev_ = next_; }
  void gaussians_changed() override;
  void gather(ProcessGroup& group, int64_t iteration) override;
  void save(Checkpoint& checkpoint, int64_t iteration) const override;
  void load(const Checkpoint& checkpoint, const LoadContext& context) override;

 private:
  // The inter-pose state one entry leaves for the same entry of the next step (detached).
  struct Chain {
    torch::Tensor descriptor, attributes, pose_feature;
    torch::Tensor decoded;  // [N] bool: rows decoded at that step (train.cull); undefined: all
  };
  // L_con of the entry against its chain (undefined when there is no pair or its weight is below
  // min_weight; the pair's weight goes to entry.consistency_weight); stores the entry's state as
  // the chain's next link.
  torch::Tensor loss(EntryContext& entry);
  void put_chains(Checkpoint& checkpoint) const;  // this rank's chains, by view

  ConsistencyConfig config_;
  bool flat_hand_mean_;
  int64_t first_entry_;
  std::vector<Chain> prev_, next_;  // one per entry of this rank: the last step's, this step's
  torch::Tensor candidates_;        // the canonical K-NN candidate sets (search = candidates)
  // Data parallel, rank 0: the other ranks' chains (consistency/view<k>/...) as of step
  // others_iteration_, gathered before each checkpoint or read from the one resumed.
  std::map<std::string, torch::Tensor> others_;
  int64_t others_iteration_ = -1;
};

}  // namespace handscs
