// Adam with named parameter groups, per-group exponential learning-rate schedules, and per-row state
// that follows densification (rows selected or appended). Update (Kingma & Ba, bias-corrected):
//   m = b1 m + (1-b1) g,  v = b2 v + (1-b2) g^2,  p -= lr (m / (1-b1^t)) / (sqrt(v / (1-b2^t)) + eps)
#pragma once

#include <string>
#include <vector>

#include <torch/types.h>

#include "run/checkpoint.h"

namespace handscs {

struct AdamGroup {
  std::string name;
  std::vector<torch::Tensor*> params;  // pointers, so a tensor replaced by densification is followed
  double lr_initial = 1e-3;
  double lr_final = 1e-3;              // reached at the last iteration (exponential interpolation)
  bool per_gaussian = false;           // rows are Gaussians (state follows select/append)
  std::vector<torch::Tensor> exp_avg;     // m, one per param
  std::vector<torch::Tensor> exp_avg_sq;  // v, one per param
};

class Adam {
 public:
  // Betas as in Adam; eps 1e-15 as in 3DGS (gradients of tiny Gaussians are tiny).
  explicit Adam(double beta1 = 0.9, double beta2 = 0.999, double eps = 1e-15);

  void add_group(const std::string& name, std::vector<torch::Tensor*> params, double lr_initial,
                 double lr_final, bool per_gaussian);

  // Learning rate of `group` at `iteration` of `total`: exponential from initial to final, times the
  // global scale (lowered after rollbacks).
  double learning_rate(const AdamGroup& group, int64_t iteration, int64_t total) const;
  void step(int64_t iteration, int64_t total);
  void zero_grad();

  // Densification: keep rows `index` of every per-Gaussian state / append `count` zero rows.
  void select_rows(const torch::Tensor& index);
  void append_rows(int64_t count);

  // Checkpoint: each parameter's moments as "adam/<group>/<i>/m" and ".../v". load() checks each
  // against its parameter's shape (Error naming `source`); a group in `fresh_groups` whose state
  // the checkpoint lacks keeps fresh moments. Steps and the learning-rate scale travel in the
  // checkpoint's metadata, not here.
  void save(Checkpoint& checkpoint) const;
  void load(const Checkpoint& checkpoint, const std::string& source,
            const std::vector<std::string>& fresh_groups);

  std::vector<AdamGroup>& groups() { return groups_; }
  int64_t steps() const { return steps_; }
  void set_steps(int64_t steps) { steps_ = steps; }
  double lr_scale() const { return lr_scale_; }
  void set_lr_scale(double scale) { lr_scale_ = scale; }

 private:
  void ensure_state(AdamGroup& group);
  double beta1_, beta2_, eps_;
  int64_t steps_ = 0;
  double lr_scale_ = 1.0;
  std::vector<AdamGroup> groups_;
};

}  // namespace handscs
