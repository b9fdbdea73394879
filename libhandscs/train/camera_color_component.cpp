#include "train/camera_color_component.h"

#include <spdlog/spdlog.h>

#include "core/atomic_file.h"

namespace handscs {

namespace {
constexpr const char* kCameraColorGroup = "camera_color";  // its optimiser group
}  // namespace

CameraColorComponent::CameraColorComponent(const TrainConfig& config,
                                           std::vector<std::string> camera_ids)
    : mode_(config.camera_color),
      penalty_weight_(config.loss.camera_color),
      camera_ids_(std::move(camera_ids)),
      colors_(std::make_unique<CameraColors>(mode_, camera_ids_)) {}

torch::Tensor CameraColorComponent::as_recorded(const std::string& camera_id,
                                                const RasterOutput& render,
                                                const std::array<float, 3>& background) const {
  const int64_t row = colors_->row(camera_id);
  return row < 0 ? render.rgb
                 : apply_color_transform(render.rgb, render.alpha, background, colors_->matrix(row));
}

void CameraColorComponent::recolor(const EntryContext&, ViewRender& view) {
  view.image = as_recorded(view.frame->camera_id, view.render, view.background);
}

void CameraColorComponent::add_penalties(const EntryContext&,
                                         std::map<std::string, torch::Tensor>& penalties) {
  // Once per entry (each entry's gradient is scaled by 1/entries): once per step in all.
  penalties["camera_color"] = colors_->penalty(penalty_weight_);
}

void CameraColorComponent::after_step(const StepContext& step) {
  // The same values on every rank, so the same projection (rank 0 reports runaways).
  colors_->project(/*warn=*/step.is_root);
}

void CameraColorComponent::add_optimizer_groups(Adam& optimizer, const LearningRates& lr) {
  optimizer.add_group(kCameraColorGroup, {&colors_->parameters()}, lr.camera_color,
                      lr.camera_color, false);
}

std::vector<std::string> CameraColorComponent::fresh_optimizer_groups() const {
  if (state_loaded_) return {};
  return {kCameraColorGroup};
}

void CameraColorComponent::save(Checkpoint& checkpoint, int64_t) const { colors_->store(checkpoint); }

void CameraColorComponent::load(const Checkpoint& checkpoint, const LoadContext& context) {
  colors_ = std::make_unique<CameraColors>(mode_, camera_ids_);
  // A checkpoint without transforms (older, or trained with camera_color off) starts them at the
  // identity, with fresh optimiser state.
  state_loaded_ = colors_->load(checkpoint, context.source);
  if (!state_loaded_)
    spdlog::info("{}: no colour transforms stored; train.camera_color starts at the identity",
                 context.source);
}

void CameraColorComponent::finish(const std::string& run_dir) const {
  write_file_atomic(run_dir + "/camera_color.csv", colors_->to_csv());
}

}  // namespace handscs
