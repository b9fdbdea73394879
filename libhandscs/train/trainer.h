// The training loop (paper §3.2-3.3): train.batch_size entries per step (one, as the paper, by
// default). An entry is one frame, or with train.views_per_pose = V up to V cameras of one pose
// whose decoding they share; each view is rendered as its ROI crop; losses, backward; Adam,
// optional densification; metrics log, validation renders, atomic checkpoints, exact resume,
// SIGINT/SIGTERM handling, and NaN/Inf steps that never reach the parameters (skip, then rollback).
//
// Data parallel (a ProcessGroup of N ranks): rank r trains entries r*B .. r*B+B-1 of each step's
// N*B (B = batch_size), gradients and densification statistics are summed across ranks in one
// all-reduce, so N ranks equal one process with batch_size N*B. Rank 0 alone writes the run folder
// (checkpoints, metrics, validation), decides densification and rollbacks and broadcasts its state
// after them (and at the start, fresh or resumed), so the ranks never diverge; NaN skips and
// Ctrl-C are agreed in the same all-reduce. Each entry keeps its own inter-pose chain (L_con pairs
// entry b of a step with entry b of the step before); a checkpoint holds rank 0's chains, so after
// resuming with several ranks the others' first step has no L_con. Pose refinement and the
// per-camera colour transforms (train.camera_color: an Adam group like the others, so their
// gradients travel in the same all-reduce) work across ranks.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "avatar/avatar.h"
#include "core/error.h"
#include "data/capture.h"
#include "run/checkpoint.h"
#include "run/run_config.h"
#include "train/adam.h"
#include "train/camera_color.h"
#include "train/data_parallel.h"
#include "train/densify.h"
#include "train/losses.h"
#include "train/pose_refine.h"
#include "train/training_checks.h"

namespace handscs {

struct StepTimes {
  double data_ms = 0, forward_ms = 0, losses_ms = 0, backward_ms = 0, optimizer_ms = 0;
};

struct StepResult {
  int64_t iteration = 0;     // the step just taken (1-based count of steps done)
  bool skipped = false;      // non-finite loss or gradient: parameters untouched
  bool rolled_back = false;  // too many skipped steps in a row: reloaded the last checkpoint
  double loss = 0;           // mean over the step's entries of their views' mean (every rank)
  double psnr = 0;           // of this step's ROI crops, likewise
  std::map<std::string, double> terms;        // unweighted loss terms (LossResult::terms), mean
                                              // over the step's entries and views (all ranks')
  // L_con's pose-similarity weight of this step and the previous one (-1: no pair); the term is
  // absent when it is below train.consistency.min_weight.
  double consistency_weight = -1;  // of the step's first entry
  std::vector<int64_t> frames;     // FrameInfo::index of each view this rank rendered, in order
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
  std::string checkpoint;  // path of the last checkpoint written (rank 0)
  CommunicationStats communication;  // data parallel: this rank's collectives over the run
  int64_t steps = 0;                 // steps taken by this run() call (a resume starts later)
  int64_t views = 0;                 // views rendered by all ranks in those steps
};

// A resume refused because its config changes the experiment's data (Trainer::resume): every
// checkpoint of the run would be refused the same way, so resume does not fall back past it.
class ExperimentChanged : public Error {
 public:
  using Error::Error;
};

class Trainer {
 public:
  // Opens the capture, builds the avatar and optimiser; removes temporaries of killed writes from
  // run_dir. config.json and the metrics.csv header are written with the first step logged or
  // checkpoint saved (write_run_files), not before. group: the data-parallel ranks
  // (null or one rank: a single process); the trainer keeps the pointer, the caller owns it.
  Trainer(const RunConfig& config, const std::string& run_dir, ProcessGroup* group = nullptr);
  ~Trainer();

  // Loads the newest valid checkpoint of run_dir (an unreadable newest one is reported and the
  // previous one used) and drops metrics.csv rows after its step. Returns false when run_dir has
  // no checkpoint; throws Error, having changed nothing, when it has some and none can be resumed
  // (damaged, or another model: the message lists the keys that differ). A resume whose config
  // changes the experiment's data (experiment_differences: capture, split, held-out poses,
  // cameras) is refused with the keys named, unless `allow_changed_data`, which warns instead.
  bool resume(bool allow_changed_data = false);
  StepResult step();
  // Runs to config.train.iterations (or until SIGINT/SIGTERM), with a progress bar.
  TrainSummary run();

  std::string save_checkpoint();  // writes checkpoints/step_<iteration>.ckpt; returns the path
  // Called once, right after the first checkpoint this trainer writes (--overwrite then deletes
  // the run it replaces).
  void on_first_checkpoint(std::function<void()> hook) { first_checkpoint_hook_ = std::move(hook); }
  bool is_root() const { return !group_ || group_->is_root(); }  // writes the run folder
  int64_t iteration() const { return iteration_; }
  Avatar& avatar() { return *avatar_; }
  Capture& capture() { return *capture_; }
  // train.camera_color: the per-camera colour transforms; null when off.
  const CameraColors* camera_colors() const { return camera_colors_.get(); }
  const RunConfig& config() const { return config_; }


 private:
  // The inter-pose state one entry leaves for the same entry of the next step (detached).
  struct ConsistencyChain {
    torch::Tensor descriptor, attributes, pose_feature;
    torch::Tensor decoded;  // [N] bool: rows decoded at that step (train.cull); undefined: all
  };
  // What a view is trained against: its ROI crop (scaled by train.resolution_scale) composited on
  // its background.
  struct ViewTarget {
    Camera camera;
    torch::Tensor target;  // [h, w, 3]
    torch::Tensor mask;    // [h, w]
    std::array<float, 3> background{};
  };
  ViewTarget load_view(const FrameInfo& frame, int64_t view_index);
  struct EntryOutcome;
  struct PoseUpdate;
  // Entry `entry` of this rank's step: its frames' pose decoded once, each frame rasterised, the
  // losses averaged over them and backpropagated (scaled to the step's mean over entries).
  EntryOutcome train_entry(int64_t entry, bool diagnostics, StepResult& result);
  // Sums this rank's gradients, densification statistics, loss, PSNR, loss terms and flags with
  // the other ranks' and divides the gradients and terms by the world size; pose_updates (this
  // rank's pose-correction gradients) become every rank's, likewise scaled. Returns whether the
  // step is finite on every rank.
  bool reduce_across_ranks(EntryOutcome& sums, bool finite, std::map<std::string, double>& terms,
                           std::vector<PoseUpdate>& pose_updates);
  // Data parallel: every rank takes rank 0's state (parameters, optimiser, counters). keep_chains:
  // the other ranks keep their inter-pose chains where the Gaussian count is unchanged.
  void synchronize_state(bool keep_chains);
  bool stop_requested() const;
  int64_t entries_per_step() const;  // batch_size on each of the ranks
  int64_t first_entry() const;       // this rank's first entry of a step
  void build_optimizer();
  void write_run_files();
  // metrics.csv's columns after the fixed ones: the model's diagnostics (and decoded_fraction with
  // train.cull).
  std::vector<std::string> diagnostic_columns() const;
  Checkpoint make_checkpoint();
  void put_chains(Checkpoint& checkpoint) const;  // this rank's inter-pose chains, by view
  void gather_chains();  // data parallel, every rank: rank 0 receives the others' chains
  // Restores the trainer from `checkpoint` (its metadata, model and experiment checked first:
  // ExperimentChanged unless `allow_changed_data`, see resume()).
  void load_from(const Checkpoint& checkpoint, const std::string& source,
                 bool allow_changed_data = false);
  bool rollback();
  // The frames entry `entry_index` (= iteration x entries_per_step() + its place in the step)
  // renders: one frame of a per-epoch shuffle of the training frames (views_per_pose 1), else up
  // to views_per_pose of the cameras, in a shuffled order, of one pose of a per-epoch shuffle of
  // the training poses.
  std::vector<const FrameInfo*> frames_for(int64_t entry_index);
  // view_index = entry_index x views_per_pose + the view's place in the entry.
  std::array<float, 3> background_for(int64_t view_index) const;
  // decoded: [N] bool, the Gaussians the pose decoded (train.cull; undefined: all); pose: the pose
  // the entry rendered (annotated, or corrected by pose refinement); chain: the entry's place in
  // the step.
  torch::Tensor consistency_loss(const AvatarState& state, const torch::Tensor& decoded,
                                 const torch::Tensor& pose, size_t chain, double* weight);
  void validate();
  void log_step(const StepResult& result);

  RunConfig config_;
  std::string run_dir_;
  ProcessGroup* group_ = nullptr;  // null: a single process
  bool stop_agreed_ = false;       // data parallel: a rank asked to stop (agreed in the all-reduce)
  std::unique_ptr<Capture> capture_;
  std::unique_ptr<Avatar> avatar_;
  std::unique_ptr<Adam> optimizer_;
  std::unique_ptr<Densifier> densifier_;
  std::unique_ptr<Objective> objective_;
  std::unique_ptr<PoseCorrections> pose_corrections_;  // null unless train.pose_refine.enabled
  std::unique_ptr<CameraColors> camera_colors_;        // null unless train.camera_color is on
  // A fresh CameraColors over the capture's training cameras (sorted ids), at the identity.
  std::unique_ptr<CameraColors> make_camera_colors() const;
  std::unique_ptr<EmptyMaskWatch> empty_masks_;
  int64_t min_loss_side_ = 1;  // smallest image side the image losses accept (training_checks.h)
  int64_t iteration_ = 0;
  int64_t skipped_total_ = 0;
  int64_t bad_in_a_row_ = 0;
  int64_t rollbacks_ = 0;
  std::string last_checkpoint_;
  std::function<void()> first_checkpoint_hook_;
  bool run_files_written_ = false;
  std::vector<std::string> metrics_columns_;  // metrics.csv's header, the order of its cells
  std::string initial_state_;  // a fresh run's step-0 checkpoint, serialised: rollback's last resort
  // Inter-pose state of the previous step, one chain per entry of this rank, this step's (pending
  // until the step is taken) and the canonical K-NN candidate sets.
  std::vector<ConsistencyChain> prev_chains_, next_chains_;
  // Data parallel, rank 0: the other ranks' inter-pose chains (consistency/view<k>/...) as of step
  // other_chains_iteration_, gathered before each checkpoint or read from the one resumed, so that
  // rank 0's checkpoints give every rank its L_con back after a resume or a rollback.
  std::map<std::string, torch::Tensor> other_chains_;
  int64_t other_chains_iteration_ = -1;
  torch::Tensor candidates_;
  std::vector<torch::Tensor> network_params_;  // the optimiser points into this vector
  double elapsed_seconds_ = 0;                 // training wall time, across resumes
  std::vector<int64_t> order_;  // frame (or pose) permutation of the current epoch
  // views_per_pose > 1: positions in capture_->train() of each training pose's frames.
  std::vector<std::vector<int64_t>> train_poses_;
  int64_t views_rendered_ = 0;  // by this process, over its lifetime
  int64_t order_epoch_ = -1;
  double running_psnr_ = 0;
};

}  // namespace handscs
