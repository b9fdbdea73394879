#include "train/densify_component.h"

#include "render/projected_radii.h"

namespace handscs {

DensifyComponent::DensifyComponent(const DensifyConfig& config, std::function<int64_t()> gaussian_count)
    : densifier_(config), gaussian_count_(std::move(gaussian_count)) {}

void DensifyComponent::before_render(const EntryContext& entry, ViewRender& view) {
  view.probe = torch::zeros({entry.avatar->gaussians().size(), 2}).requires_grad_(true);
}

void DensifyComponent::after_backward(const EntryContext& entry) {
  // The densification threshold is per view: undo the 1/(entries x views) of the means.
  const int64_t count = static_cast<int64_t>(entry.views.size());
  const double weight = double(entry.entries * count);
  const AvatarState& state = *entry.state;
  Densifier::ViewStatistics sum;  // over the entry's views
  for (int64_t k = 0; k < count; ++k) {
    const ViewRender& view = entry.views[k];
    const auto grad = view.probe.grad().defined() ? view.probe.grad() : torch::zeros_like(view.probe);
    // train.cull: a skipped Gaussian counts as seen, with no gradient, by every view whose exact
    // render would have projected it (its un-offset geometry and own opacity): it is on the
    // hand's far side, where the exact render's gradient is that of an occluded Gaussian (counting
    // it as unseen densified 60% more of the back's Gaussians).
    const auto radii =
        entry.decoded.defined()
            ? torch::where(entry.decoded, view.render.radii,
                           projected_radii(state.posed.means, state.posed.covariances,
                                           torch::sigmoid(entry.avatar->gaussians().opacity_logits),
                                           view.camera, {}))
            : view.render.radii;
    const auto s = Densifier::view_statistics(weight == 1 ? grad : grad * weight, radii);
    sum.grad_norm = k == 0 ? s.grad_norm : sum.grad_norm + s.grad_norm;
    sum.visible = k == 0 ? s.visible : sum.visible + s.visible;
  }
  // Summed over the step's entries first, then over the ranks: the same sums on every layout.
  const bool first = !step_.visible.defined();
  step_.grad_norm = first ? sum.grad_norm : step_.grad_norm + sum.grad_norm;
  step_.visible = first ? sum.visible : step_.visible + sum.visible;
}

void DensifyComponent::contribute(ReduceSlots& slots) const {
  // Two hands: a rank whose entries did not show this hand adds zeros, so every rank adds the
  // same slots; "present" tells whether any rank showed it.
  const bool shown = step_.visible.defined();
  const torch::Tensor none = shown ? torch::Tensor() : torch::zeros({gaussian_count_()});
  slots.add("densify/grad_norm", shown ? step_.grad_norm : none);
  slots.add("densify/visible", shown ? step_.visible : none);
  slots.add_scalar("densify/present", shown ? 1 : 0);
}

void DensifyComponent::receive(const ReduceSlots& slots, double) {
  if (slots.scalar("densify/present") == 0) {
    step_ = {};
    return;
  }
  step_.grad_norm = slots.get("densify/grad_norm").clone();
  step_.visible = slots.get("densify/visible").clone();
}

void DensifyComponent::after_step(const StepContext& step) {
  // A step whose entries did not show this hand (data.hand both) adds no statistics.
  if (step_.visible.defined()) densifier_.add(step_);
  step_ = {};
  // Decided once, by rank 0, from statistics every rank holds; the others take its result.
  if (densifier_.due(step.iteration) && step.is_root)
    densifier_.densify_and_prune(step.avatar->gaussians(), *step.optimizer,
                                 step.seed + static_cast<uint64_t>(step.iteration));
}

void DensifyComponent::save(Checkpoint& checkpoint, int64_t) const { densifier_.save(checkpoint); }

void DensifyComponent::load(const Checkpoint& checkpoint, const LoadContext&) {
  densifier_.load(checkpoint);  // replaces both statistics (undefined when the checkpoint has none)
  step_ = {};
}

}  // namespace handscs
