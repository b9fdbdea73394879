// The training loop (paper §3.2-3.3): one view per step, render the ROI crop, losses, backward,
// Adam, optional densification; metrics log, validation renders, atomic checkpoints, exact resume,
// SIGINT/SIGTERM handling, and NaN/Inf steps that never reach the parameters (skip, then rollback).
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <string>

#include "avatar/avatar.h"
#include "data/capture.h"
#include "train/adam.h"
#include "train/checkpoint.h"
#include "train/densify.h"
#include "train/losses.h"
#include "train/pose_refine.h"
#include "train/run_config.h"
#include "train/training_checks.h"

namespace handscs {

struct StepTimes {
  double data_ms = 0, forward_ms = 0, losses_ms = 0, backward_ms = 0, optimizer_ms = 0;
};

struct StepResult {
  int64_t iteration = 0;     // the step just taken (1-based count of steps done)
  bool skipped = false;      // non-finite loss or gradient: parameters untouched
  bool rolled_back = false;  // too many skipped steps in a row: reloaded the last checkpoint
  double loss = 0;
  double psnr = 0;           // of this step's ROI crop
  std::map<std::string, double> terms;        // unweighted loss terms (LossResult::terms)
  // L_con's pose-similarity weight of this step and the previous one (-1: no pair); the term is
  // absent when it is below train.consistency.min_weight.
  double consistency_weight = -1;
  std::map<std::string, double> diagnostics;  // decoder gates, mean offset norms (metrics.csv),
                                              // on steps whose count is a multiple of log_every
  StepTimes times;
};

struct TrainSummary {
  int64_t iterations = 0;
  double seconds = 0;
  int64_t skipped_steps = 0;
  int64_t rollbacks = 0;
  int64_t gaussians = 0;
  bool interrupted = false;
  std::string checkpoint;  // path of the last checkpoint written
};

class Trainer {
 public:
  // Opens the capture, builds the avatar and optimiser; removes temporaries of killed writes from
  // run_dir. config.json and the metrics.csv header are written with the first step logged,
  // checkpoint saved or run() (write_run_files), not before.
  Trainer(const RunConfig& config, const std::string& run_dir);
  ~Trainer();

  // Loads the newest valid checkpoint of run_dir (an unreadable newest one is reported and the
  // previous one used) and drops metrics.csv rows after its step. Returns false when run_dir has
  // no checkpoint; throws Error, having changed nothing, when it has some and none can be resumed
  // (damaged, or another model: the message lists the keys that differ).
  bool resume();
  StepResult step();
  // Runs to config.train.iterations (or until SIGINT/SIGTERM), with a progress bar.
  TrainSummary run();

  std::string save_checkpoint();  // writes checkpoints/step_<iteration>.ckpt; returns the path
  int64_t iteration() const { return iteration_; }
  Avatar& avatar() { return *avatar_; }
  Capture& capture() { return *capture_; }
  const RunConfig& config() const { return config_; }


 private:
  void build_optimizer();
  void write_run_files();
  Checkpoint make_checkpoint();
  void load_from(const Checkpoint& checkpoint, const std::string& source);
  bool rollback();
  const FrameInfo& frame_for(int64_t iteration);
  std::array<float, 3> background_for(int64_t iteration) const;
  // pose: the pose the step rendered (annotated, or corrected by pose refinement).
  torch::Tensor consistency_loss(const AvatarState& state, const torch::Tensor& pose,
                                 double* weight);
  void validate();
  void log_step(const StepResult& result);

  RunConfig config_;
  std::string run_dir_;
  std::unique_ptr<Capture> capture_;
  std::unique_ptr<Avatar> avatar_;
  std::unique_ptr<Adam> optimizer_;
  std::unique_ptr<Densifier> densifier_;
  std::unique_ptr<Objective> objective_;
  std::unique_ptr<PoseCorrections> pose_corrections_;  // null unless train.pose_refine.enabled
  std::unique_ptr<EmptyMaskWatch> empty_masks_;
  int64_t min_loss_side_ = 1;  // smallest image side the image losses accept (training_checks.h)
  int64_t iteration_ = 0;
  int64_t skipped_total_ = 0;
  int64_t bad_in_a_row_ = 0;
  int64_t rollbacks_ = 0;
  std::string last_checkpoint_;
  bool run_files_written_ = false;
  // Inter-pose state of the previous step (detached) and the canonical K-NN candidate sets.
  torch::Tensor prev_descriptor_, prev_attributes_, prev_pose_feature_, candidates_;
  torch::Tensor next_descriptor_, next_attributes_, next_pose_feature_;  // this step's, pending
  std::vector<torch::Tensor> network_params_;  // the optimiser points into this vector
  double elapsed_seconds_ = 0;                 // training wall time, across resumes
  std::vector<int64_t> order_;  // frame permutation of the current epoch
  int64_t order_epoch_ = -1;
  double running_psnr_ = 0;
};

}  // namespace handscs
