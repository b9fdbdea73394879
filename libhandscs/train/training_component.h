// A part of training with its own state: the per-camera colour, pose refinement, densification,
// the inter-pose chains of L_con, the facing cull, the LPIPS schedule. The Trainer keeps the loop,
// the data, the avatar and its optimiser, and the run folder; at fixed points of each step it asks
// every component, in order, for its part. A component overrides only the points it needs.
//
// One entry of a step (one pose and its views), in order:
//   before_decode   may change the pose decoded (pose refinement) or how (the cull)
//   before_render   per view, before rasterising (the densification probe)
//   recolor         per view, the image its camera records (per-camera colour)
//   prepare_loss    inputs of the image losses shared by the views (L_con, the LPIPS step)
//   add_penalties   terms added once per entry, each logged under its name
//   diagnostics     values for metrics.csv on logged steps
//   after_backward  reads the entry's gradients (densification statistics, pose updates)
// Then once per step: contribute/receive (data parallel: named slots of the step's all-reduce),
// finite, and after_step (the optimiser stepped) or after_skipped_step (a non-finite step).
//
// Checkpoints: each component writes its own section (save) and reads it back (load), deciding
// itself what a resume may change (a section absent from an older checkpoint starts fresh).
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <torch/types.h>

#include "avatar/avatar.h"
#include "avatar/facing_cull.h"
#include "data/capture.h"
#include "run/checkpoint.h"
#include "train/adam.h"
#include "train/data_parallel.h"
#include "train/losses.h"
#include "train/reduce_slots.h"

namespace handscs {

// One view of an entry: its target's camera and background, then its render.
struct ViewRender {
  const FrameInfo* frame = nullptr;
  Camera camera;                      // of the (scaled) ROI crop
  std::array<float, 3> background{};
  torch::Tensor probe;   // [N, 2] zeros that take dL/d means2d (densification); else undefined
  RasterOutput render;
  torch::Tensor image;   // what the losses compare: render.rgb, as the view's camera records it
};

// The entry being trained, filled in as the step goes.
struct EntryContext {
  int64_t iteration = 0;   // steps taken before this one
  int64_t entry = 0;       // place in this rank's step
  int64_t step_entry = 0;  // place among every rank's entries of the step
  int64_t entries = 1;     // this rank's entries per step (each entry's loss is scaled by 1/entries)
  Avatar* avatar = nullptr;
  const FrameInfo* frame = nullptr;  // the pose, shape and translation of its views
  torch::Tensor pose, trans;         // decoded: the annotation, unless a component corrects it
  bool need_descriptor = false;      // decode the structural descriptor P (L_con)
  std::optional<FacingCull> cull;
  const AvatarState* state = nullptr;  // from the decode on
  torch::Tensor decoded;  // [N] bool, the rows decoded (the cull); undefined: every row
  std::vector<ViewRender> views;
  double consistency_weight = -1;  // L_con's pose-similarity weight (-1: no pair)
};

// What the step's end gives components (after the optimiser step or a skipped step).
struct StepContext {
  int64_t iteration = 0;  // steps taken, this one included
  Avatar* avatar = nullptr;
  Adam* optimizer = nullptr;
  bool is_root = true;    // rank 0 (or a single process): decides what every rank then takes
  uint64_t seed = 0;      // train.seed
};

struct LoadContext {
  std::string source;  // the checkpoint's name, for messages
  Avatar* avatar = nullptr;  // as restored from the checkpoint
  int64_t iteration = 0;           // the checkpoint's step
  bool data_parallel_root = false;  // rank 0 of several ranks
  // Data parallel: the state comes from rank 0 (a start, a densification or a rollback) and a
  // component may keep what is its own rank's where it still fits (the inter-pose chains).
  bool keep_own_state = false;
};

class TrainingComponent {
 public:
  virtual ~TrainingComponent() = default;

  virtual void before_decode(EntryContext&) {}
  virtual void before_render(const EntryContext&, ViewRender&) {}
  virtual void recolor(const EntryContext&, ViewRender&) {}
  virtual void prepare_loss(EntryContext&, LossInputs&) {}
  virtual void add_penalties(const EntryContext&, std::map<std::string, torch::Tensor>&) {}
  virtual void diagnostics(const EntryContext&, std::map<std::string, double>&) {}
  virtual void after_backward(const EntryContext&) {}
  // metrics.csv columns of its diagnostics beyond the model's fixed ones.
  virtual std::vector<std::string> metrics_columns() const { return {}; }

  // Data parallel: adds this rank's share of the step; receive() reads the sums (scaled where
  // a mean over ranks is meant, inverse_ranks = 1 / world size).
  virtual void contribute(ReduceSlots&) const {}
  virtual void receive(const ReduceSlots&, double /*inverse_ranks*/) {}
  // Single process: whether what the component will apply is finite (the all-reduce checks all).
  virtual bool finite() const { return true; }
  virtual void after_step(const StepContext&) {}
  virtual void after_skipped_step() {}
  // Whether after_step() of step `iteration` may change the Gaussians (rank 0 decides; data
  // parallel, the other ranks then take its state).
  virtual bool may_change_gaussians(int64_t /*iteration*/) const { return false; }
  // The Gaussians' rows changed (densification): state that refers to rows starts afresh.
  virtual void gaussians_changed() {}

  // Optimiser groups of the component's own parameters (after the avatar's).
  virtual void add_optimizer_groups(Adam&, const LearningRates&) {}
  // Groups whose optimiser state a checkpoint may lack (the component starts them fresh).
  virtual std::vector<std::string> fresh_optimizer_groups() const { return {}; }

  // Data parallel, every rank, when a checkpoint is due: gathers what rank 0 must save for all.
  virtual void gather(ProcessGroup&, int64_t /*iteration*/) {}
  virtual void save(Checkpoint&, int64_t /*iteration*/) const {}
  virtual void load(const Checkpoint&, const LoadContext&) {}
  // Once, when the run ends (rank 0): the component's own files in the run folder.
  virtual void finish(const std::string& /*run_dir*/) const {}
};

}  // namespace handscs
