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
// Ctrl-C are agreed in the same all-reduce.
//
// The parts of training beyond the avatar and its optimiser (pose refinement, the facing cull, the
// LPIPS schedule, L_con's inter-pose chains, per-camera colour, densification) are components
// (training_component.h): each adds its part at fixed points of the step, its own slots to the
// all-reduce and its own section to checkpoints. The Trainer keeps the loop, the data, the avatar
// and the run folder.
//
// Two hands (data.hand both): each hand has its own avatar, optimiser and components (pose
// refinement, the cull, L_con, densification); the LPIPS schedule and the per-camera colour are
// shared. Each view rasterises both hands' Gaussians in one call, so that each hides the other;
// a frame without one of the hands trains the other. The second hand's state is the checkpoint
// section "left" (run/checkpoint.h), its metrics.csv diagnostics are prefixed "left_".
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "avatar/avatar.h"
#include "core/error.h"
#include "data/capture.h"
#include "data/capture_identity.h"
#include "run/checkpoint.h"
#include "run/run_config.h"
#include "train/adam.h"
#include "train/camera_color_component.h"
#include "train/data_parallel.h"
#include "train/entry_order.h"
#include "train/losses.h"
#include "train/training_checks.h"
#include "train/train_memory.h"
#include "train/training_component.h"
#include "train/view_target.h"

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
  // One step. A failed allocation ends it with an Error naming the step, the Gaussian count and
  // the keys that lower what a step needs.
  StepResult step();
  // Runs to config.train.iterations (or until SIGINT/SIGTERM), with a progress bar. A failed
  // allocation while validating or saving a checkpoint is named as a step's is.
  TrainSummary run();

  // Writes checkpoints/step_<iteration>.ckpt; returns the path. A failed allocation is named as a
  // step's is; the checkpoints already written stay as they were.
  std::string save_checkpoint();
  // Renders the first test frame (the first training frame when there is none) into
  // validation/step_<iteration>.png beside the truth and the error; a failed allocation is named.
  void validate();
  // Called once, right after the first checkpoint this trainer writes (--overwrite then deletes
  // the run it replaces).
  void on_first_checkpoint(std::function<void()> hook) { first_checkpoint_hook_ = std::move(hook); }
  bool is_root() const { return !group_ || group_->is_root(); }  // writes the run folder
  int64_t iteration() const { return iteration_; }
  Avatar& avatar() { return *hands_.front().avatar; }  // the first hand's (right with both)
  Avatar& avatar(Handedness side);  // Error when the run does not train that hand
  int hand_count() const { return static_cast<int>(hands_.size()); }
  int64_t gaussian_count() const;  // of every hand
  // The run's peak memory, estimated from its settings, the capture's crops and the Gaussians each
  // hand has now (train/train_memory.h).
  TrainMemoryEstimate memory_estimate();
  Capture& capture() { return *capture_; }
  // train.camera_color: the per-camera colour transforms; null when off.
  const CameraColors* camera_colors() const {
    return camera_color_ ? &camera_color_->colors() : nullptr;
  }
  const RunConfig& config() const { return config_; }


 private:
  // The view's target (view_target.h), its empty mask recorded. view_index = entry_index x
  // views_per_pose + the view's place in the entry.
  ViewTarget load_view(const FrameInfo& frame, int64_t view_index);
  struct EntryOutcome;
  struct HandEntry;
  // Entry `entry` of this rank's step: its frames' pose decoded once, each frame rasterised, the
  // losses averaged over them and backpropagated (scaled to the step's mean over entries).
  EntryOutcome train_entry(int64_t entry, bool diagnostics, StepResult& result);
  StepResult take_step();  // step() without its out-of-memory message
  // Returns f(); a failed allocation in it ends the run with an Error naming `when`, the Gaussian
  // count at that moment and the keys that lower what a run needs (train/out_of_memory.h).
  template <class F>
  auto naming_out_of_memory(const std::string& when, F&& f);
  // The entry's frames (their indices appended to result.frames) and their targets.
  // `hands`: a context per hand the frames show, with its views.
  EntryContext start_entry(int64_t entry, std::vector<ViewTarget>& targets, StepResult& result,
                           std::vector<HandEntry>& hands);
  // Decodes each hand's pose and renders each view of the entry (the hands together).
  void render_entry(EntryContext& ctx, std::vector<HandEntry>& hands);
  // The entry's loss: the mean over its views, plus each hand's pose terms and the components'
  // penalties (terms: each term's value, unweighted, summed over the hands).
  torch::Tensor entry_loss(EntryContext& ctx, std::vector<HandEntry>& hands,
                           const std::vector<ViewTarget>& targets,
                           std::map<std::string, double>& terms);
  // Sums this rank's gradients, loss, PSNR, loss terms, flags and the components' slots with the
  // other ranks' in one all-reduce and divides the gradients and terms by the world size. Returns
  // whether the step is finite on every rank.
  bool reduce_across_ranks(EntryOutcome& sums, bool finite, std::map<std::string, double>& terms);
  // Data parallel: every rank takes rank 0's state (parameters, optimiser, counters, components).
  // keep_own_state: the other ranks' components keep what is their own where it still fits (the
  // inter-pose chains, where the Gaussian count is unchanged).
  void synchronize_state(bool keep_own_state);
  // The components train.* turns on, in the order the step asks them.
  void make_components();
  bool stop_requested() const;
  // Data parallel, every rank, when a checkpoint is due: each component gathers what rank 0 saves.
  void gather_components();
  int64_t entries_per_step() const;  // batch_size on each of the ranks
  int64_t first_entry() const;       // this rank's first entry of a step
  void build_optimizer();
  void write_run_files();
  // metrics.csv's columns after the fixed ones: the model's diagnostics (and decoded_fraction with
  // train.cull).
  std::vector<std::string> diagnostic_columns() const;
  Checkpoint make_checkpoint();
  // Restores the trainer from `checkpoint` (its metadata, model and experiment checked first:
  // ExperimentChanged unless `allow_changed_data`, see resume()). keep_own_state: see
  // synchronize_state().
  void load_from(const Checkpoint& checkpoint, const std::string& source,
                 bool allow_changed_data = false, bool keep_own_state = false);
  bool rollback();
  void render_validation();
  std::string write_checkpoint();
  void log_step(const StepResult& result);

  RunConfig config_;
  std::string run_dir_;
  ProcessGroup* group_ = nullptr;  // null: a single process
  bool stop_agreed_ = false;       // data parallel: a rank asked to stop (agreed in the all-reduce)
  // One hand's avatar and what trains it.
  struct HandSlot {
    Handedness side = Handedness::right;
    // "" for the first hand; the second's checkpoint section and metrics.csv prefix ("left").
    std::string section;
    std::unique_ptr<Avatar> avatar;
    std::unique_ptr<Adam> optimizer;  // its own: densification selects and appends its rows
    std::vector<torch::Tensor> network_params;  // the optimiser points into this vector
    std::vector<std::unique_ptr<TrainingComponent>> components;
  };
  // model.shared_decoders with two hands: the second hand decodes with the first's decoders.
  void share_decoders();
  // Every optimiser: each hand's, then the shared components'.
  std::vector<Adam*> optimizers();
  // Calls `f(components, section)` for each hand's components and then for the shared ones
  // (section "").
  template <class F>
  void for_each_part(F&& f);

  std::unique_ptr<Capture> capture_;
  CaptureIdentity capture_identity_;  // the capture's, stored in every checkpoint
  nlohmann::json placement_;          // the hands of the first training frame (data/placement.h), likewise
  bool accepted_changed_data_ = false;  // resumed with --resume-changing-data (rollbacks too)
  std::vector<HandSlot> hands_;  // right first
  std::unique_ptr<Adam> optimizer_;  // the shared components' parameters
  std::unique_ptr<Objective> objective_;
  // The components the hands share: the LPIPS schedule, the per-camera colour.
  std::vector<std::unique_ptr<TrainingComponent>> components_;
  CameraColorComponent* camera_color_ = nullptr;  // among components_; null when off
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
  double elapsed_seconds_ = 0;                 // training wall time, across resumes
  std::unique_ptr<EntryOrder> entry_order_;  // the frames each entry renders
  int64_t views_rendered_ = 0;  // by this process, over its lifetime
  double running_psnr_ = 0;
};

}  // namespace handscs
