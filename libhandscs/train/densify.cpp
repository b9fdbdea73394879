#include "train/densify.h"
#include "render/rotation.h"

#include <torch/types.h>

namespace handscs {

namespace {
// 3DGS divides the scales of the two halves of a split Gaussian by 0.8 * 2 = 1.6.
constexpr double kSplitScaleDivisor = 1.6;
}  // namespace

void Densifier::reset(int64_t n) {
  grad_sum_ = torch::zeros({n}, torch::kFloat32);
  count_ = torch::zeros({n}, torch::kFloat32);
}

Densifier::ViewStatistics Densifier::view_statistics(const torch::Tensor& means2d_grad,
                                                     const torch::Tensor& radii) {
  torch::NoGradGuard no_grad;
  const auto visible = (radii > 0).to(torch::kFloat32);
  return {means2d_grad.to(torch::kFloat32).norm(2, 1) * visible, visible};
}

void Densifier::add(const ViewStatistics& statistics) {
  const int64_t n = statistics.visible.size(0);
  if (!grad_sum_.defined() || grad_sum_.size(0) != n) reset(n);
  torch::NoGradGuard no_grad;
  grad_sum_ += statistics.grad_norm;
  count_ += statistics.visible;
}

int64_t Densifier::densify_and_prune(GaussianState& g, Adam& optimizer, uint64_t seed) {
  torch::NoGradGuard no_grad;
  const int64_t n = g.size();
  if (!grad_sum_.defined() || grad_sum_.size(0) != n) reset(n);
  const auto mean_grad = grad_sum_ / count_.clamp_min(1.0);
  const auto max_scale = torch::exp(g.log_scales.detach()).amax(1);
  auto candidates = mean_grad >= config_.grad_threshold;

  // Budget: never exceed the cap; keep the strongest gradients when there are too many candidates.
  const int64_t budget = std::max<int64_t>(0, config_.max_gaussians - n);
  auto picked = candidates.nonzero().squeeze(1);
  if (picked.size(0) > budget) {
    const auto order = std::get<1>(mean_grad.index_select(0, picked).sort(0, /*descending=*/true));
    picked = picked.index_select(0, order.slice(0, 0, budget));
  }
  const auto big = max_scale.index_select(0, picked) > config_.split_extent;
  const auto clone_ids = picked.index_select(0, (~big).nonzero().squeeze(1));
  const auto split_ids = picked.index_select(0, big.nonzero().squeeze(1));

  // Clones: exact copies (the optimiser moves them apart). Splits: two samples from the Gaussian,
  // appended, then the original is removed.
  GaussianState added = g.select(torch::cat({clone_ids, split_ids, split_ids}));
  const int64_t num_clones = clone_ids.size(0), num_splits = split_ids.size(0);
  if (num_splits > 0) {
    auto gen = at::detail::createCPUGenerator(seed);
    auto halves = added.select(torch::arange(num_clones, added.size(), torch::kInt64));
    const auto rot = quaternion_to_matrix(halves.rotations.detach());
    const auto sigma = torch::exp(halves.log_scales.detach());
    const auto sample = at::normal(0.0, 1.0, {2 * num_splits, 3}, gen, torch::kFloat32);
    const auto offset = rot.matmul((sample * sigma).unsqueeze(2)).squeeze(2);
    auto means = added.means.detach().clone();
    means.slice(0, num_clones) += offset;
    auto log_scales = added.log_scales.detach().clone();
    log_scales.slice(0, num_clones) -= std::log(kSplitScaleDivisor);
    added.means = means.requires_grad_(true);
    added.log_scales = log_scales.requires_grad_(true);
  }
  if (added.size() > 0) {
    g.append(added);
    optimizer.append_rows(added.size());
  }

  // Remove split originals and transparent Gaussians.
  auto keep = torch::sigmoid(g.opacity_logits.detach()) >= config_.min_opacity;
  if (num_splits > 0) keep.index_fill_(0, split_ids, false);
  if (!keep.any().item<bool>()) keep.fill_(true);  // never prune the avatar away entirely
  if (!keep.all().item<bool>()) {
    const auto index = keep.nonzero().squeeze(1);
    g = g.select(index);
    optimizer.select_rows(index);
  }
  reset(g.size());
  return g.size();
}

void Densifier::save(Checkpoint& checkpoint) const {
  if (grad_sum_.defined()) checkpoint.tensors["densify/grad_sum"] = grad_sum_.clone();
  if (count_.defined()) checkpoint.tensors["densify/count"] = count_.clone();
}

void Densifier::load(const Checkpoint& checkpoint) {
  const auto grad_sum = checkpoint.tensors.find("densify/grad_sum");
  const auto count = checkpoint.tensors.find("densify/count");
  grad_sum_ = grad_sum == checkpoint.tensors.end() ? torch::Tensor() : grad_sum->second.clone();
  count_ = count == checkpoint.tensors.end() ? torch::Tensor() : count->second.clone();
}

}  // namespace handscs
