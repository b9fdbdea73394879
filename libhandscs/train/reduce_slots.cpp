#include "train/reduce_slots.h"

#include "core/error.h"

namespace handscs {

void ReduceSlots::add(const std::string& unscoped, const torch::Tensor& values) {
  const std::string name = scope_ + unscoped;
  require(!index_.count(name), "ReduceSlots: slot '" + name + "' added twice");
  index_[name] = slots_.size();
  slots_.emplace_back(name, values.detach().to(torch::kFloat32));
}

void ReduceSlots::add_scalar(const std::string& name, double value) {
  add(name, torch::tensor({static_cast<float>(value)}, torch::kFloat32));
}

void ReduceSlots::all_reduce(ProcessGroup& group) {
  std::vector<torch::Tensor> parts;
  for (const auto& [name, position] : index_) parts.push_back(slots_[position].second.reshape(-1));
  if (parts.empty()) return;
  auto buffer = torch::cat(parts).contiguous();
  group.all_reduce_sum(buffer);
  int64_t offset = 0;
  for (const auto& [name, position] : index_) {
    auto& slot = slots_[position].second;
    const int64_t n = slot.numel();
    slot = buffer.slice(0, offset, offset + n).view(slot.sizes());
    offset += n;
  }
}

torch::Tensor ReduceSlots::get(const std::string& unscoped) const {
  const std::string name = scope_ + unscoped;
  const auto it = index_.find(name);
  require(it != index_.end(), "ReduceSlots: no slot '" + name + "'");
  return slots_[it->second].second;
}

double ReduceSlots::scalar(const std::string& name) const { return get(name).item<double>(); }

bool ReduceSlots::all_finite() const {
  for (const auto& [name, values] : slots_)
    if (!torch::isfinite(values).all().item<bool>()) return false;
  return true;
}

}  // namespace handscs
