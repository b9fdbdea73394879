#include "run/avatar_state_io.h"

#include <torch/types.h>

#include "core/config.h"
#include "core/error.h"
#include "data/placement.h"
#include "run/checkpoint_meta.h"

namespace handscs {

namespace {
std::vector<std::pair<std::string, torch::Tensor>> network_tensors(Avatar& avatar) {
  std::vector<std::pair<std::string, torch::Tensor>> out;
  auto add = [&](const std::string& prefix, torch::nn::Module& module) {
    for (const auto& item : module.named_parameters()) out.push_back({prefix + item.key(), item.value()});
    for (const auto& item : module.named_buffers()) out.push_back({prefix + item.key(), item.value()});
  };
  add("network/decoders.", *avatar.decoders());
  if (avatar.generator()) add("network/generator.", *avatar.generator());
  return out;
}
}  // namespace

void store_avatar(Avatar& avatar, Checkpoint& checkpoint) {
  for (auto& [name, tensor] : avatar.gaussians().all())
    checkpoint.tensors["gaussians/" + name] = tensor->detach().clone();
  for (auto& [name, tensor] : network_tensors(avatar))
    checkpoint.tensors[name] = tensor.detach().clone();
}

Avatar restore_avatar(const Checkpoint& checkpoint, const AvatarConfig& config, Rig rig,
                      const std::string& source) {
  Avatar avatar(config, std::move(rig));
  auto find = [&](const std::string& name) -> const torch::Tensor& {
    auto it = checkpoint.tensors.find(name);
    if (it == checkpoint.tensors.end()) throw Error(source + ": checkpoint lacks tensor " + name);
    return it->second;
  };
  for (auto& [name, tensor] : avatar.gaussians().all()) {
    const auto& stored = find("gaussians/" + name);
    if (stored.dim() != tensor->dim() || (stored.dim() > 1 && stored.size(1) != tensor->size(1)))
      throw Error(source + ": gaussians/" + name + " has shape " + c10::str(stored.sizes()) +
                  ", the config expects [N, " + std::to_string(tensor->dim() > 1 ? tensor->size(1) : 0) +
                  "]");
    const bool learn = tensor->requires_grad();
    *tensor = stored.clone();
    if (learn) tensor->set_requires_grad(true);
  }
  const int64_t n = avatar.gaussians().size();
  for (auto& [name, tensor] : avatar.gaussians().all())
    if (tensor->size(0) != n)
      throw Error(source + ": gaussians/" + name + " has " + std::to_string(tensor->size(0)) +
                  " rows, means has " + std::to_string(n));
  torch::NoGradGuard no_grad;
  for (auto& [name, tensor] : network_tensors(avatar)) {
    const auto& stored = find(name);
    if (stored.sizes() != tensor.sizes())
      throw Error(source + ": " + name + " has shape " + c10::str(stored.sizes()) +
                  ", the config expects " + c10::str(tensor.sizes()));
    tensor.copy_(stored);
  }
  return avatar;
}

void refuse_model_overrides(const std::vector<std::string>& overrides) {
  // The avatar is the checkpoint's: a model key set here would be ignored, or contradict the weights.
  // data.rig and data.flat_hand_mean are the model's too (RunConfig: one rig for masks and avatar).
  for (const auto& assignment : overrides) {
    if (assignment.rfind("model.", 0) == 0 || assignment.rfind("model=", 0) == 0)
      throw Error("--set " + assignment + ": the model is the checkpoint's and cannot be changed "
                  "after training (data.*, eval.* and train.* keys can be set)");
    if (assignment.rfind("data.rig=", 0) == 0 || assignment.rfind("data.flat_hand_mean=", 0) == 0)
      throw Error("--set " + assignment + ": the rig is the checkpoint's (data.rig and "
                  "data.flat_hand_mean serve the model) and cannot be changed after training");
  }
}

TrainedAvatar open_trained_avatar(const std::string& checkpoint_or_run,
                                  const std::vector<std::string>& overrides) {
  refuse_model_overrides(overrides);
  const OpenedCheckpoint opened = open_checkpoint(checkpoint_or_run);
  check_checkpoint_meta(opened.checkpoint.meta, opened.path);
  // The stored config as trained, then with the overrides merged as JSON (read again, once).
  json stored = opened.checkpoint.meta.at("config");
  RunConfig trained_config;
  config_from_json(stored, opened.path + kStoredConfig, trained_config);
  apply_overrides(stored, overrides);
  RunConfig config;
  config_from_json(stored, opened.path + kStoredConfig + (overrides.empty() ? "" : kWithOverrides),
                   config);
  const std::vector<Handedness> sides = hand_sides(trained_config.data.hand);  // the weights' hands
  Avatar avatar = restore_avatar(opened.checkpoint, config.model, avatar_rig(trained_config, sides.front()),
                                 opened.path);
  CameraColorTable colors = CameraColorTable::from_checkpoint(opened.checkpoint, opened.path);
  std::vector<Avatar> left;
  if (sides.size() > 1) {
    const std::string section = hand_name(Handedness::left);
    if (!opened.checkpoint.meta.contains(section))
      throw Error(opened.path + ": checkpoint lacks the left hand (its data.hand is both)");
    left.push_back(restore_avatar(checkpoint_section(opened.checkpoint, section), config.model,
                                  avatar_rig(trained_config, Handedness::left), opened.path));
  }
  std::optional<CaptureIdentity> identity;
  if (const auto it = opened.checkpoint.meta.find(kCaptureIdentityKey); it != opened.checkpoint.meta.end())
    identity = CaptureIdentity::from_json(*it, opened.path + ": " + kCaptureIdentityKey);
  const nlohmann::json placement = opened.checkpoint.meta.value(kPlacementKey, nlohmann::json());
  return {opened.path,       std::move(config), std::move(trained_config), std::move(avatar),
          std::move(colors), std::move(left),   identity,
          placement};
}

Handedness TrainedAvatar::first_hand() const { return hand_sides(trained_config.data.hand).front(); }

int64_t TrainedAvatar::gaussian_count() {
  int64_t count = avatar.gaussians().size();
  for (Avatar& other : left) count += other.gaussians().size();
  return count;
}

Avatar* TrainedAvatar::hand(Handedness side) {
  if (first_hand() == side) return &avatar;
  if (side == Handedness::left && !left.empty()) return &left.front();
  return nullptr;
}

}  // namespace handscs
