#include "train/adam.h"

#include <algorithm>
#include <cmath>

#include <torch/types.h>

#include "core/error.h"

namespace handscs {

Adam::Adam(double beta1, double beta2, double eps) : beta1_(beta1), beta2_(beta2), eps_(eps) {}

void Adam::add_group(const std::string& name, std::vector<torch::Tensor*> params,
                     double lr_initial, double lr_final, bool per_gaussian) {
  AdamGroup group;
  group.name = name;
  group.params = std::move(params);
  group.lr_initial = lr_initial;
  group.lr_final = lr_final;
  group.per_gaussian = per_gaussian;
  ensure_state(group);
  groups_.push_back(std::move(group));
}

void Adam::ensure_state(AdamGroup& group) {
  group.exp_avg.resize(group.params.size());
  group.exp_avg_sq.resize(group.params.size());
  for (size_t i = 0; i < group.params.size(); ++i) {
    const auto& p = *group.params[i];
    if (!group.exp_avg[i].defined() || group.exp_avg[i].sizes() != p.sizes()) {
      group.exp_avg[i] = torch::zeros_like(p, torch::MemoryFormat::Contiguous).detach();
      group.exp_avg_sq[i] = torch::zeros_like(p, torch::MemoryFormat::Contiguous).detach();
    }
  }
}

double Adam::learning_rate(const AdamGroup& group, int64_t iteration, int64_t total) const {
  double lr = group.lr_initial;
  if (group.lr_final != group.lr_initial && total > 1 && group.lr_initial > 0 && group.lr_final > 0) {
    const double progress = std::min(1.0, std::max(0.0, double(iteration) / double(total - 1)));
    lr = std::exp((1 - progress) * std::log(group.lr_initial) + progress * std::log(group.lr_final));
  }
  return lr * lr_scale_;
}

void Adam::step(int64_t iteration, int64_t total) {
  torch::NoGradGuard no_grad;
  ++steps_;
  const double correction1 = 1 - std::pow(beta1_, steps_);
  const double correction2 = 1 - std::pow(beta2_, steps_);
  for (auto& group : groups_) {
    const double lr = learning_rate(group, iteration, total);
    for (size_t i = 0; i < group.params.size(); ++i) {
      auto& p = *group.params[i];
      if (!p.grad().defined() || p.numel() == 0) continue;
      const auto& g = p.grad();
      auto& m = group.exp_avg[i];
      auto& v = group.exp_avg_sq[i];
      m.mul_(beta1_).add_(g, 1 - beta1_);
      v.mul_(beta2_).addcmul_(g, g, 1 - beta2_);
      const auto denom = (v / correction2).sqrt_().add_(eps_);
      p.addcdiv_(m, denom, -lr / correction1);
    }
  }
}

void Adam::zero_grad() {
  for (auto& group : groups_)
    for (auto* p : group.params)
      if (p->grad().defined()) p->mutable_grad().reset();
}

void Adam::select_rows(const torch::Tensor& index) {
  for (auto& group : groups_) {
    if (!group.per_gaussian) continue;
    for (size_t i = 0; i < group.params.size(); ++i) {
      group.exp_avg[i] = group.exp_avg[i].index_select(0, index);
      group.exp_avg_sq[i] = group.exp_avg_sq[i].index_select(0, index);
    }
  }
}

void Adam::append_rows(int64_t count) {
  for (auto& group : groups_) {
    if (!group.per_gaussian) continue;
    for (size_t i = 0; i < group.params.size(); ++i) {
      auto sizes = group.exp_avg[i].sizes().vec();
      sizes[0] = count;
      const auto zeros = torch::zeros(sizes, group.exp_avg[i].options());
      group.exp_avg[i] = torch::cat({group.exp_avg[i], zeros}, 0);
      group.exp_avg_sq[i] = torch::cat({group.exp_avg_sq[i], zeros}, 0);
    }
  }
}

void Adam::save(Checkpoint& checkpoint) const {
  for (const auto& group : groups_)
    for (size_t i = 0; i < group.params.size(); ++i) {
      const std::string base = "adam/" + group.name + "/" + std::to_string(i);
      checkpoint.tensors[base + "/m"] = group.exp_avg[i].clone();
      checkpoint.tensors[base + "/v"] = group.exp_avg_sq[i].clone();
    }
}

void Adam::load(const Checkpoint& checkpoint, const std::string& source,
                const std::vector<std::string>& fresh_groups) {
  for (auto& group : groups_) {
    const bool may_be_fresh =
        std::find(fresh_groups.begin(), fresh_groups.end(), group.name) != fresh_groups.end();
    for (size_t i = 0; i < group.params.size(); ++i) {
      const std::string base = "adam/" + group.name + "/" + std::to_string(i);
      const auto m = checkpoint.tensors.find(base + "/m");
      const auto v = checkpoint.tensors.find(base + "/v");
      if (may_be_fresh) continue;
      if (m == checkpoint.tensors.end() || v == checkpoint.tensors.end())
        throw Error(source + ": checkpoint lacks optimiser state " + base);
      if (m->second.sizes() != group.params[i]->sizes())
        throw Error(source + ": optimiser state " + base + " does not match its parameter");
      group.exp_avg[i] = m->second.clone();
      group.exp_avg_sq[i] = v->second.clone();
    }
  }
}

}  // namespace handscs
