#include "train/pose_refine_component.h"

#include <spdlog/spdlog.h>

#include "core/atomic_file.h"

namespace handscs {

PoseRefineComponent::PoseRefineComponent(int64_t num_poses, const PoseRefineConfig& config,
                                         int64_t entries_per_step)
    : num_poses_(num_poses),
      config_(config),
      entries_per_step_(entries_per_step),
      corrections_(std::make_unique<PoseCorrections>(num_poses, config)) {}

void PoseRefineComponent::before_decode(EntryContext& entry) {
  const bool learn = entry.iteration >= config_.start;
  const CorrectedPose corrected =
      corrections_->apply(entry.frame->pose_index, entry.pose, entry.trans, learn);
  entry.pose = corrected.pose;
  entry.trans = corrected.trans;
  if (deltas_.size() <= static_cast<size_t>(entry.entry)) deltas_.resize(entry.entry + 1);
  deltas_[entry.entry] = corrected.delta.requires_grad() ? corrected.delta : torch::Tensor();
}

void PoseRefineComponent::add_penalties(const EntryContext& entry,
                                        std::map<std::string, torch::Tensor>& penalties) {
  const torch::Tensor& delta = deltas_[entry.entry];
  if (delta.defined()) penalties["pose_refine"] = corrections_->penalty(delta);
}

void PoseRefineComponent::diagnostics(const EntryContext&, std::map<std::string, double>& values) {
  for (const auto& [name, value] : corrections_->summary()) values[name] = value;
}

void PoseRefineComponent::after_backward(const EntryContext& entry) {
  const torch::Tensor& delta = deltas_[entry.entry];
  if (delta.defined() && delta.grad().defined())
    updates_.push_back({entry.step_entry, entry.frame->pose_index, delta.grad()});
}

void PoseRefineComponent::contribute(ReduceSlots& slots) const {
  // One slot per entry of the step over every rank (flag, pose index, gradient), this rank's
  // filled and the others' zero, so the sum hands every rank every update (an all-gather by
  // all-reduce). Pose indices are exact in float32 up to 2^24.
  auto table = torch::zeros({entries_per_step_, 2 + PoseCorrections::kWidth});
  for (const auto& update : updates_) {
    table[update.step_entry][0] = 1.0;
    table[update.step_entry][1] = static_cast<double>(update.pose_index);
    table[update.step_entry].slice(0, 2).copy_(update.grad.reshape(-1));
  }
  slots.add("pose_refine/updates", table);
}

void PoseRefineComponent::receive(const ReduceSlots& slots, double inverse_ranks) {
  // Gradients scaled as the parameters' (the mean over every rank's entries), in entry order.
  const auto table = slots.get("pose_refine/updates");
  updates_.clear();
  for (int64_t entry = 0; entry < entries_per_step_; ++entry)
    if (table[entry][0].item<float>() > 0)
      updates_.push_back({entry, static_cast<int64_t>(table[entry][1].item<float>()),
                          table[entry].slice(0, 2) * inverse_ranks});
}

bool PoseRefineComponent::finite() const {
  for (const auto& update : updates_)
    if (!torch::isfinite(update.grad).all().item<bool>()) return false;
  return true;
}

void PoseRefineComponent::after_step(const StepContext&) {
  for (const auto& update : updates_) corrections_->step(update.pose_index, update.grad);
  updates_.clear();
}

void PoseRefineComponent::save(Checkpoint& checkpoint, int64_t) const {
  for (const auto& [name, tensor] : corrections_->state()) checkpoint.tensors[name] = tensor;
}

void PoseRefineComponent::load(const Checkpoint& checkpoint, const LoadContext& context) {
  corrections_ = std::make_unique<PoseCorrections>(num_poses_, config_);
  updates_.clear();
  if (checkpoint.tensors.count("pose_refine/values"))
    corrections_->load_state(checkpoint.tensors, context.source);
  else
    spdlog::info("{}: no pose corrections stored; pose refinement starts from the annotations",
                 context.source);
}

void PoseRefineComponent::finish(const std::string& run_dir) const {
  write_file_atomic(run_dir + "/pose_refine.csv", corrections_->to_csv());
}

}  // namespace handscs
