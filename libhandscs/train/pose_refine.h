// Training-pose refinement (beyond the paper, off by default): a correction per training pose of
// the annotated MANO pose (global orientation and 15 joints, axis-angle) and translation, learned
// with the avatar. Annotations carry fit error (NeuralAnnot on InterHand2.6M; the realistic
// synthetic capture adds it on purpose); GauHuman and 3DGS-Avatar refine the body pose per training
// frame in the same way. Test poses are never corrected: evaluation uses the annotations, as the
// paper's protocol has it.
//
// A correction d (51 values) applies as pose + d[0:48] and trans + kTransUnit d[48:51]: translation
// is learned in units of kTransUnit, so one learning rate and one penalty weight fit both (a
// rotation by d rad moves a point kTransUnit away by kTransUnit d m). The penalty
// reg |d|^2 keeps corrections of little-seen joints at zero. Each row has its own Adam state and
// step count: a pose's row is updated only on the steps that render it, so its moments are not
// decayed by the steps of other poses.
#pragma once

#include <cstdint>
#include <map>
#include <string>

#include <torch/types.h>

#include "run/train_config.h"

namespace handscs {

struct CorrectedPose {
  torch::Tensor pose;   // [48] annotated + correction
  torch::Tensor trans;  // [3]
  torch::Tensor delta;  // [51] the row's correction (a leaf with requires_grad when learned)
};

class PoseCorrections {
 public:
  // Metres per unit of the translation part of a correction: a hand's radius from the wrist (m).
  static constexpr double kTransUnit = 0.1;
  static constexpr int64_t kWidth = 51;  // 48 pose + 3 translation

  PoseCorrections(int64_t num_poses, const PoseRefineConfig& config);

  // The corrected pose of row `row` (a training pose's pose_index). learn: the correction takes
  // gradients (read by step()); otherwise it applies as a constant.
  CorrectedPose apply(int64_t row, const torch::Tensor& pose, const torch::Tensor& trans,
                      bool learn) const;
  // reg |delta|^2 (a scalar that backpropagates into delta).
  torch::Tensor penalty(const torch::Tensor& delta) const;
  // One Adam step of row `row` with the gradient of its correction (bias-corrected per row).
  void step(int64_t row, const torch::Tensor& grad);

  // Root mean square over the rows updated at least once: finger-joint rotation angle (deg),
  // global rotation angle (deg), translation length (mm). Zeros before any update.
  std::map<std::string, double> summary() const;
  // CSV of every updated row: pose_index, steps, the three sizes above, then the 51 values.
  std::string to_csv() const;

  int64_t rows() const { return values_.size(0); }
  // State for checkpoints (copied in and out as named tensors).
  std::map<std::string, torch::Tensor> state() const;
  // Restores state(); throws Error naming `source` when shapes do not match.
  void load_state(const std::map<std::string, torch::Tensor>& state, const std::string& source);

 private:
  PoseRefineConfig config_;
  torch::Tensor values_;      // [P, 51] float64
  torch::Tensor exp_avg_;     // [P, 51]
  torch::Tensor exp_avg_sq_;  // [P, 51]
  torch::Tensor steps_;       // [P] int64: Adam steps taken by each row
};

}  // namespace handscs
