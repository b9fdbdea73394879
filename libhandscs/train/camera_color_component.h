// train.camera_color as a training component: each view's image as its camera records the
// avatar's colours, the transforms' penalty, their optimiser group, the projection after each
// step, their checkpoint section and the run's camera_color.csv.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "train/camera_color.h"
#include "train/training_component.h"

namespace handscs {

class CameraColorComponent : public TrainingComponent {
 public:
  // camera_ids: the training cameras, sorted (the same rows on every rank and every run).
  CameraColorComponent(const TrainConfig& config, std::vector<std::string> camera_ids);

  const CameraColors& colors() const { return *colors_; }
  // rgb [h, w, 3] as camera `camera_id` records it (unchanged for a camera without a transform).
  torch::Tensor as_recorded(const std::string& camera_id, const RasterOutput& render,
                            const std::array<float, 3>& background) const;

  void recolor(const EntryContext&, ViewRender& view) override;
  void add_penalties(const EntryContext&, std::map<std::string, torch::Tensor>& penalties) override;
  void after_step(const StepContext& step) override;
  void add_optimizer_groups(Adam& optimizer, const LearningRates& lr) override;
  std::vector<std::string> fresh_optimizer_groups() const override;
  void save(Checkpoint& checkpoint, int64_t iteration) const override;
  void load(const Checkpoint& checkpoint, const LoadContext& context) override;
  void finish(const std::string& run_dir) const override;

 private:
  TrainConfig::CameraColor mode_;
  double penalty_weight_;
  std::vector<std::string> camera_ids_;
  std::unique_ptr<CameraColors> colors_;
  bool state_loaded_ = true;  // false: the checkpoint loaded held no transforms (fresh Adam state)
};

}  // namespace handscs
