#include "train/consistency_component.h"

#include <set>

#include "train/consistency.h"
#include "train/descriptor_tree.h"

namespace handscs {

namespace {

// Checkpoint names of the inter-pose chain of the step's view `view` (view 0 keeps the names of
// the single-view format, so older checkpoints resume).
std::string chain_prefix(int64_t view) {
  return view == 0 ? "consistency/" : "consistency/view" + std::to_string(view) + "/";
}

}  // namespace

ConsistencyComponent::ConsistencyComponent(const ConsistencyConfig& config, bool flat_hand_mean,
                                           int64_t entries, int64_t first_entry)
    : config_(config),
      flat_hand_mean_(flat_hand_mean),
      first_entry_(first_entry),
      prev_(entries),
      next_(entries) {}

void ConsistencyComponent::prepare_loss(EntryContext& entry, LossInputs& inputs) {
  // One term per pose: the same for each of its views.
  inputs.consistency = loss(entry);
}

torch::Tensor ConsistencyComponent::loss(EntryContext& entry) {
  const Chain& prev = prev_[entry.entry];
  const AvatarState& state = *entry.state;
  auto& g = entry.avatar->gaussians();
  auto pose = entry.pose.detach().to(torch::kFloat32).clone();
  if (!flat_hand_mean_) pose.slice(0, 3, 48) += entry.avatar->rig().hands_mean.to(torch::kFloat32);
  const auto feature = pose_feature(pose);
  const auto attributes =
      consistency_attributes(state.canonical_means, state.canonical_covariances,
                             state.canonical_colors, g.embed_geometry, g.embed_appearance);
  torch::Tensor loss;
  const double weight =
      prev.descriptor.defined() ? pose_similarity(feature, prev.pose_feature, config_.delta) : 0.0;
  if (prev.descriptor.defined()) entry.consistency_weight = weight;
  if (prev.descriptor.defined() && prev.descriptor.size(0) == g.size() &&
      weight >= config_.min_weight) {
    torch::Tensor match;
    const bool gemm = config_.search == ConsistencyConfig::Search::exact ||
                      (config_.search == ConsistencyConfig::Search::automatic &&
                       g.size() <= config_.exact_max_gaussians);
    if (gemm) {
      match = correspond_exact(state.descriptor, prev.descriptor);
    } else if (config_.search == ConsistencyConfig::Search::candidates) {
      if (!candidates_.defined() || candidates_.size(0) != g.size() ||
          entry.iteration % config_.refresh_every == 0)
        candidates_ = nearest_neighbours(g.means, config_.candidates);
      match = correspond_candidates(state.descriptor, prev.descriptor, candidates_);
    } else {
      // Rows persist between steps (the state is reset on densification): each Gaussian's own
      // previous row is the natural first guess.
      match = DescriptorTree(prev.descriptor)
                  .nearest(state.descriptor, torch::arange(g.size(), torch::kInt64));
    }
    auto diff = consistency_distances(attributes, prev.attributes.index_select(0, match),
                                      state.canonical_covariances, config_.normalize);
    // train.cull: a pair counts only when both of its Gaussians were decoded (the others carry
    // no offsets at their step).
    if (entry.decoded.defined() || prev.decoded.defined())
      diff = diff.index_select(0, pairs_decoded_at_both_steps(entry.decoded, prev.decoded, match));
    if (diff.numel() > 0)
      loss = weight *
             (config_.reduction == ConsistencyConfig::Reduction::sum ? diff.sum() : diff.mean());
  }
  // Kept for the next step (M_0 = M_1 on the first step: no loss).
  next_[entry.entry] = {state.descriptor.detach(), attributes.detach(), feature, entry.decoded};
  return loss;
}

void ConsistencyComponent::gaussians_changed() {
  // Correspondences refer to rows: start the inter-pose state afresh.
  prev_.assign(prev_.size(), Chain{});
  candidates_ = torch::Tensor();
}

void ConsistencyComponent::put_chains(Checkpoint& checkpoint) const {
  for (size_t i = 0; i < prev_.size(); ++i) {
    const std::string prefix = chain_prefix(first_entry_ + static_cast<int64_t>(i));
    const Chain& chain = prev_[i];
    for (const auto& [field, tensor] :
         {std::pair<const char*, const torch::Tensor&>{"descriptor", chain.descriptor},
          {"attributes", chain.attributes},
          {"pose_feature", chain.pose_feature},
          {"decoded", chain.decoded}})
      if (tensor.defined()) checkpoint.tensors[prefix + field] = tensor.clone();
  }
}

void ConsistencyComponent::gather(ProcessGroup& group, int64_t iteration) {
  // Each other rank's chains travel as a checkpoint of those tensors alone; rank 0 keeps them.
  Checkpoint mine;  // rank 0 sends nothing
  if (!group.is_root()) put_chains(mine);
  if (group.is_root()) others_.clear();
  for (int rank = 1; rank < group.world_size(); ++rank) {
    std::string bytes = group.rank() == rank ? checkpoint_bytes(mine) : std::string();
    group.broadcast_bytes(bytes, rank);
    if (!group.is_root()) continue;
    const std::string source = "rank " + std::to_string(rank) + "'s inter-pose chains";
    for (auto& [name, tensor] : checkpoint_from_bytes(bytes, source).tensors) others_[name] = tensor;
  }
  others_iteration_ = iteration;
}

void ConsistencyComponent::save(Checkpoint& checkpoint, int64_t iteration) const {
  put_chains(checkpoint);
  if (others_iteration_ == iteration)
    for (const auto& [name, tensor] : others_) checkpoint.tensors.emplace(name, tensor);
  if (candidates_.defined()) checkpoint.tensors["consistency/candidates"] = candidates_.clone();
}

void ConsistencyComponent::load(const Checkpoint& checkpoint, const LoadContext& context) {
  const auto get = [&](const std::string& name) {
    auto it = checkpoint.tensors.find(name);
    return it == checkpoint.tensors.end() ? torch::Tensor() : it->second.clone();
  };
  const std::vector<Chain> own = prev_;
  for (size_t i = 0; i < prev_.size(); ++i) {
    const std::string prefix = chain_prefix(first_entry_ + static_cast<int64_t>(i));
    prev_[i] = {get(prefix + "descriptor"), get(prefix + "attributes"),
                get(prefix + "pose_feature"), get(prefix + "decoded")};
  }
  // Taking rank 0's state: this rank keeps its own chains where the Gaussian count is unchanged.
  if (context.keep_own_state)
    for (size_t i = 0; i < own.size(); ++i)
      if (own[i].descriptor.defined() &&
          own[i].descriptor.size(0) == context.avatar->gaussians().size())
        prev_[i] = own[i];
  // Rank 0 keeps the other ranks' chains of the checkpoint: the broadcast that starts (or rolls
  // back) every rank then carries them.
  others_.clear();
  others_iteration_ = -1;
  if (context.data_parallel_root) {
    std::set<std::string> own_prefixes;
    for (size_t i = 0; i < prev_.size(); ++i)
      own_prefixes.insert(chain_prefix(first_entry_ + static_cast<int64_t>(i)));
    const std::string views = "consistency/view";
    for (const auto& [name, tensor] : checkpoint.tensors) {
      if (name.rfind(views, 0) != 0) continue;
      if (!own_prefixes.count(name.substr(0, name.find('/', views.size()) + 1)))
        others_[name] = tensor.clone();
    }
    others_iteration_ = context.iteration;
  }
  candidates_ = get("consistency/candidates");
}

}  // namespace handscs
