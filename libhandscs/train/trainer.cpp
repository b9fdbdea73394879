#include "train/trainer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <random>
#include <set>
#include <sstream>
#include <utility>

#include <opencv2/imgproc.hpp>
#include <spdlog/spdlog.h>
#include <torch/types.h>

#include "core/atomic_file.h"
#include "core/config.h"
#include "core/error.h"
#include "core/float_vector.h"
#include "core/progress.h"
#include "core/stop_signal.h"
#include "data/camera_transforms.h"
#include "data/placement.h"
#include "io/png.h"
#include "metrics/comparison_panel.h"
#include "metrics/image_tensor.h"
#include "metrics/psnr.h"
#include "run/avatar_state_io.h"
#include "run/checkpoint_meta.h"
#include "train/consistency_component.h"
#include "train/cull_component.h"
#include "train/densify_component.h"
#include "train/entry_order.h"
#include "train/lpips_schedule.h"
#include "train/out_of_memory.h"
#include "train/pose_refine_component.h"
#include "train/run_folder.h"

namespace handscs {

namespace {

using Clock = std::chrono::steady_clock;
double ms_between(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double, std::milli>(b - a).count();
}

constexpr int kMaxRollbacks = 20;    // after this many the run is declared diverged
constexpr int kPrefetchAhead = 4;    // frames queued for the background loader
// A run fails when this many first training images (shuffled) all have empty hand masks: the
// chance that a working capture gives 16 empty masks in a row is negligible, and 16 steps of a
// tiny run cost seconds.
constexpr int64_t kEmptyMaskSteps = 16;
const char* kMetricsColumns[] = {"iteration", "seconds", "loss", "rgb", "mask", "ssim", "lpips",
                                 "reg", "consistency", "psnr", "gaussians", "skipped", "rollbacks",
                                 "lr_scale", "data_ms", "forward_ms", "losses_ms", "backward_ms",
                                 "optimizer_ms"};
// What the model uses, logged after kMetricsColumns (StepResult::diagnostics keys, in this order).
const char* kDiagnosticColumns[] = {"gate_geometry", "gate_appearance", "gate_fusion",
                                    "offset_dx", "offset_dsigma", "offset_dc",
                                    "offset_dx_f", "offset_dsigma_f", "offset_dc_f",
                                    "pose_refine_deg", "pose_refine_global_deg", "pose_refine_mm"};
// ... then the components' own (TrainingComponent::metrics_columns).
// The loss terms a step reports (StepResult::terms): data parallel sums them across ranks.
const char* kReducedTerms[] = {"rgb",         "mask",       "ssim",        "lpips", "reg",
                               "consistency", "pose_refine", "camera_color"};

// train.cull: [N] bool, true for the Gaussians the pose decoded; undefined when it decoded all.
torch::Tensor decoded_mask(const AvatarState& state) {
  if (!state.decoded_rows.defined()) return {};
  return torch::zeros({state.posed.means.size(0)}, torch::kBool).index_fill_(0, state.decoded_rows, true);
}

// Whether the decoders do anything: their gates and the mean size of each offset (metrics.csv).
void decoder_diagnostics(Avatar& avatar, const AvatarState& state,
                         std::map<std::string, double>& values) {
  torch::NoGradGuard no_grad;
  const auto& decoders = avatar.decoders();
  values["gate_geometry"] = decoders->geometry->gate.item<double>();
  values["gate_appearance"] = decoders->appearance->gate.item<double>();
  values["gate_fusion"] = decoders->fusion->gate.item<double>();
  for (const auto& [name, norms] : offset_norms(state.offsets)) {
    const auto kept = state.decoded_rows.defined() ? norms.index_select(0, state.decoded_rows) : norms;
    values["offset_" + name] = kept.mean().item<double>();
  }
}

}  // namespace

Trainer::Trainer(const RunConfig& config, const std::string& run_dir, ProcessGroup* group)
    : config_(config), run_dir_(run_dir), group_(group) {
  validate_run_config(config_, "config");
  if (group_ && group_->world_size() == 1) group_ = nullptr;
  ensure_directory(run_dir_);  // its checkpoints/ comes with the first checkpoint
  if (is_root()) remove_stale_temporaries(run_dir_);

  capture_ = std::make_unique<Capture>(Capture::open(config_.data, run_dir_ + "/cache"));
  require(!capture_->train().empty(),
          "data: the capture has no training frames (check data.root, split, capture, cameras)");
  capture_identity_ = capture_identity(*capture_, capture_->frames());
  placement_ = training_placement(capture_->train());
  entry_order_ = std::make_unique<EntryOrder>(capture_->train(), config_.train.views_per_pose,
                                              config_.train.seed);
  if (is_root()) {
    spdlog::info("capture: {} training and {} test frames, {} poses, {} cameras",
               capture_->train().size(), capture_->test().size(), capture_->num_poses(),
               capture_->cameras().size());
    const std::string batch_warning =
        batch_size_warning(config_.train.batch_size, group_ ? group_->world_size() : 1,
                           static_cast<int64_t>(capture_->train().size()));
    if (!batch_warning.empty()) spdlog::warn("{}", batch_warning);
    if (config_.data.hand == CaptureConfig::Hands::both)
      if (const std::string missing = missing_hand_warning(capture_->train()); !missing.empty())
        spdlog::warn("{}", missing);
  }

  for (const Handedness side : hand_sides(config_.data.hand)) {
    HandSlot hand;
    hand.side = side;
    hand.section = hands_.empty() ? "" : hand_name(side);
    hand.avatar = std::make_unique<Avatar>(config_.model, avatar_rig(config_, side));
    hands_.push_back(std::move(hand));
  }
  share_decoders();
  make_components();
  build_optimizer();

  std::shared_ptr<const Lpips> lpips;
  if (config_.train.loss.lpips > 0) {
    if (config_.eval.lpips.weights.empty())
      spdlog::warn("LPIPS loss skipped: eval.lpips.weights is empty (set it to an LPIPS weight file)");
    else
      lpips = std::make_shared<const Lpips>(config_.eval.lpips);
  }
  objective_ = std::make_unique<Objective>(config_.train.loss, lpips);
  min_loss_side_ = min_loss_image_side(config_.train.loss, lpips.get());
  check_training_image_sizes(capture_->train(), config_.train.resolution_scale, min_loss_side_);
  empty_masks_ = std::make_unique<EmptyMaskWatch>(
      std::min<int64_t>(kEmptyMaskSteps, static_cast<int64_t>(capture_->train().size())));
}

std::vector<std::string> Trainer::diagnostic_columns() const {
  std::vector<std::string> columns;
  for (const HandSlot& hand : hands_) {
    const std::string prefix = hand.section.empty() ? "" : hand.section + "_";
    for (const char* column : kDiagnosticColumns) columns.push_back(prefix + column);
    for (const auto& component : hand.components)
      for (const std::string& column : component->metrics_columns()) columns.push_back(prefix + column);
  }
  for (const auto& component : components_)
    for (const std::string& column : component->metrics_columns()) columns.push_back(column);
  return columns;
}

Avatar& Trainer::avatar(Handedness side) {
  for (HandSlot& hand : hands_)
    if (hand.side == side) return *hand.avatar;
  throw Error("the run trains no " + hand_name(side) + " hand (data.hand is " + hand_name(config_.data.hand) + ")");
}

std::vector<Adam*> Trainer::optimizers() {
  std::vector<Adam*> out;
  for (HandSlot& hand : hands_) out.push_back(hand.optimizer.get());
  out.push_back(optimizer_.get());
  return out;
}

template <class F>
void Trainer::for_each_part(F&& f) {
  for (HandSlot& hand : hands_) f(hand.components, hand.section);
  f(components_, std::string());
}

void Trainer::write_run_files() {
  // Not in the constructor: a resume that fails (or a config that fails later checks) must leave
  // the folder as it was.
  if (run_files_written_) return;
  write_file_atomic(run_dir_ + "/config.json", config_to_json(config_).dump(2) + "\n");
  std::vector<std::string> columns(std::begin(kMetricsColumns), std::end(kMetricsColumns));
  for (const std::string& column : diagnostic_columns()) columns.push_back(column);
  metrics_columns_ = prepare_metrics_log(run_dir_ + "/metrics.csv", columns);
  run_files_written_ = true;
}

Trainer::~Trainer() = default;

void Trainer::make_components() {
  const TrainConfig& train = config_.train;
  // Each hand's, in this order: pose refinement corrects the pose the cull, L_con and the decode
  // then see; its penalty is added before the colour transforms'.
  for (HandSlot& hand : hands_) {
    auto& components = hand.components;
    if (train.pose_refine.enabled)
      components.push_back(std::make_unique<PoseRefineComponent>(capture_->num_poses(),
                                                                 train.pose_refine, entries_per_step()));
    if (train.cull.enabled) components.push_back(std::make_unique<CullComponent>(train.cull.max_cos));
    if (train.loss.consistency > 0)
      components.push_back(std::make_unique<ConsistencyComponent>(
          train.consistency, config_.model.flat_hand_mean, train.batch_size, first_entry()));
    if (train.densify.enabled) {
      // hands_ is complete and never grows, so `hand` stays where it is; its avatar may be replaced.
      const HandSlot* slot = &hand;
      components.push_back(std::make_unique<DensifyComponent>(
          train.densify, [slot] { return slot->avatar->gaussians().size(); }));
    }
  }
  components_.push_back(std::make_unique<LpipsSchedule>(train.loss.lpips_every));
  if (train.camera_color != TrainConfig::CameraColor::off) {
    std::set<std::string> ids;  // sorted: the same rows on every rank and every run
    for (const auto& frame : capture_->train()) ids.insert(frame.camera_id);
    auto component = std::make_unique<CameraColorComponent>(
        train, std::vector<std::string>(ids.begin(), ids.end()));
    camera_color_ = component.get();
    components_.push_back(std::move(component));
  }
}

void Trainer::share_decoders() {
  if (!config_.model.shared_decoders || hands_.size() < 2) return;
  for (size_t i = 1; i < hands_.size(); ++i) hands_[i].avatar->share_decoders(*hands_.front().avatar);
}

void Trainer::build_optimizer() {
  const auto& lr = config_.train.lr;
  for (HandSlot& hand : hands_) {
    // Shared decoders are stepped once, by the first hand's optimiser, with both hands' gradients.
    const bool decoders_elsewhere = config_.model.shared_decoders && &hand != &hands_.front();
    auto& g = hand.avatar->gaussians();
    hand.optimizer = std::make_unique<Adam>();
    Adam& adam = *hand.optimizer;
    adam.add_group("means", {&g.means}, lr.means, lr.means_final, true);
    adam.add_group("log_scales", {&g.log_scales}, lr.log_scales, lr.log_scales, true);
    adam.add_group("rotations", {&g.rotations}, lr.rotations, lr.rotations, true);
    adam.add_group("colors", {&g.colors}, lr.colors, lr.colors, true);
    adam.add_group("opacity", {&g.opacity_logits}, lr.opacity, lr.opacity, true);
    adam.add_group("embeddings", {&g.embed_geometry, &g.embed_appearance}, lr.embeddings,
                   lr.embeddings, true);
    hand.network_params.clear();
    auto groups = hand.avatar->network_parameter_groups();
    size_t total = 0;
    for (auto& [name, params] : groups) total += params.size();
    hand.network_params.reserve(total);  // pointers into this vector stay valid: no reallocation
    for (auto& [name, params] : groups) {
      if (decoders_elsewhere && (name == "decoders" || name == "gates")) continue;
      std::vector<torch::Tensor*> pointers;
      for (auto& p : params) {
        hand.network_params.push_back(p);
        pointers.push_back(&hand.network_params.back());
      }
      if (name == "gates")
        adam.add_group(name, pointers, lr.gates, lr.gates, false);
      else
        adam.add_group(name, pointers, lr.networks, lr.networks_final, false);
    }
    // After the avatar's, so that its groups are as without the components.
    for (auto& component : hand.components) component->add_optimizer_groups(adam, lr);
  }
  optimizer_ = std::make_unique<Adam>();
  for (auto& component : components_) component->add_optimizer_groups(*optimizer_, lr);
}

int64_t Trainer::entries_per_step() const {
  return config_.train.batch_size * (group_ ? group_->world_size() : 1);
}

int64_t Trainer::first_entry() const {
  return config_.train.batch_size * (group_ ? group_->rank() : 0);
}

bool Trainer::stop_requested() const { return group_ ? stop_agreed_ : StopSignal::requested(); }

// One hand's part of an entry: the frames as that hand sees them (frame_of_hand), its context
// (the avatar, the pose, its views with their probes) and its decoded state.
struct Trainer::HandEntry {
  HandSlot* hand = nullptr;
  FrameInfo frame;
  EntryContext ctx;
  AvatarState state;
};

// What one entry of a step leaves behind after its backward (its gradients are in the parameters).
struct Trainer::EntryOutcome {
  double loss = 0;  // mean over the entry's views, unweighted by the step's entry count
  double psnr = 0;  // mean over the entry's views
  int64_t views = 0;
};

ViewTarget Trainer::load_view(const FrameInfo& frame, int64_t view_index) {
  FrameSample sample = capture_->load(frame);
  empty_masks_->record(frame, !sample.mask.any().item<bool>());
  return make_view_target(sample, frame, config_.train.resolution_scale, min_loss_side_,
                          training_background(config_.train.background, config_.train.seed, view_index));
}

EntryContext Trainer::start_entry(int64_t entry, std::vector<ViewTarget>& targets,
                                  StepResult& result, std::vector<HandEntry>& hands) {
  const int64_t entry_index = iteration_ * entries_per_step() + first_entry() + entry;
  const std::vector<const FrameInfo*> frames = entry_order_->frames_for(entry_index);
  EntryContext ctx;
  ctx.iteration = iteration_;
  ctx.entry = entry;
  ctx.step_entry = first_entry() + entry;
  ctx.entries = config_.train.batch_size;
  ctx.avatar = hands_.front().avatar.get();
  ctx.frame = frames.front();  // the pose, shape and translation of them all
  for (const FrameInfo* frame : frames) result.frames.push_back(frame->index);
  for (size_t k = 0; k < frames.size(); ++k) {
    targets.push_back(load_view(*frames[k], entry_index * config_.train.views_per_pose +
                                                static_cast<int64_t>(k)));
    ViewRender view;
    view.frame = frames[k];
    view.camera = targets.back().camera;
    view.background = targets.back().background;
    ctx.views.push_back(std::move(view));
  }
  // The hands the frames show (one hand: always its own). reserve: the contexts point into it.
  hands.reserve(hands_.size());
  for (HandSlot& hand : hands_) {
    const bool present = hands_.size() == 1 || ctx.frame->hand(hand.side) != nullptr;
    if (!present) continue;
    hands.emplace_back();
    HandEntry& h = hands.back();
    h.hand = &hand;
    h.frame = frame_of_hand(*ctx.frame, hand.side);
    h.ctx = ctx;
    h.ctx.avatar = hand.avatar.get();
    h.ctx.frame = &h.frame;
  }
  return ctx;
}

void Trainer::render_entry(EntryContext& ctx, std::vector<HandEntry>& hands) {
  // Each hand's pose is decoded once; each view rasterises the hands' posed Gaussians together.
  std::vector<const PosedGaussians*> posed;
  for (HandEntry& h : hands) {
    EntryContext& hand_ctx = h.ctx;
    hand_ctx.pose = float_vector(h.frame.pose);
    hand_ctx.trans = float_vector(h.frame.trans);
    for (auto& component : h.hand->components) component->before_decode(hand_ctx);
    h.state = h.hand->avatar->pose(hand_ctx.pose, float_vector(h.frame.shape), hand_ctx.trans,
                                   hand_ctx.need_descriptor, hand_ctx.cull ? &*hand_ctx.cull : nullptr);
    hand_ctx.state = &h.state;
    hand_ctx.decoded = decoded_mask(h.state);
    posed.push_back(&h.state.posed);
  }
  const bool single = hands.size() == 1;
  if (single) ctx.state = &hands.front().state;
  const PosedGaussians joined = join_posed(posed);
  for (size_t k = 0; k < ctx.views.size(); ++k) {
    ViewRender& view = ctx.views[k];
    std::vector<torch::Tensor> probes;
    for (HandEntry& h : hands) {
      for (auto& component : h.hand->components) component->before_render(h.ctx, h.ctx.views[k]);
      probes.push_back(h.ctx.views[k].probe);
    }
    for (auto& component : components_) component->before_render(ctx, view);
    // The hands' probes as one (a hand without one adds zeros that nothing reads).
    torch::Tensor probe = probes.front();
    if (!single && std::any_of(probes.begin(), probes.end(), [](const auto& t) { return t.defined(); })) {
      for (size_t i = 0; i < probes.size(); ++i)
        if (!probes[i].defined()) probes[i] = torch::zeros({posed[i]->means.size(0), 2});
      probe = torch::cat(probes, 0);
    } else if (!single) {
      probe = torch::Tensor();
    }
    RasterSettings settings;
    settings.background = view.background;
    view.render = render_posed(joined, view.camera, settings, probe);
    view.image = view.render.rgb;
    // Each hand's view holds the render with its own Gaussians' radii.
    int64_t row = 0;
    for (size_t i = 0; i < hands.size(); ++i) {
      ViewRender& own = hands[i].ctx.views[k];
      const int64_t rows = posed[i]->means.size(0);
      own.render = view.render;
      if (!single) own.render.radii = view.render.radii.slice(0, row, row + rows);
      own.image = view.image;
      row += rows;
    }
    for (auto& component : components_) component->recolor(ctx, view);
  }
}

torch::Tensor Trainer::entry_loss(EntryContext& ctx, std::vector<HandEntry>& hands,
                                  const std::vector<ViewTarget>& targets,
                                  std::map<std::string, double>& terms) {
  // What the views' losses share: the first hand's pose terms (as in a one-hand run), the LPIPS
  // step. The other hand's pose terms are added once below.
  LossInputs shared;
  HandEntry& first = hands.front();
  shared.offsets = &first.state.offsets;
  shared.decoded_rows = first.state.decoded_rows;
  for (auto& component : first.hand->components) component->prepare_loss(first.ctx, shared);
  for (auto& component : components_) component->prepare_loss(ctx, shared);
  ctx.consistency_weight = first.ctx.consistency_weight;
  // The entry's loss is the mean over its views (the pose's terms, L_reg and L_con, are the same
  // in each, so they count once).
  const int64_t count = static_cast<int64_t>(ctx.views.size());
  torch::Tensor total;
  for (int64_t k = 0; k < count; ++k) {
    LossInputs in = shared;
    in.rgb = ctx.views[k].image;
    in.alpha = ctx.views[k].render.alpha;
    in.target = targets[k].target;
    in.mask = targets[k].mask;
    auto loss = objective_->compute(in);
    total = k == 0 ? loss.total : total + loss.total;
    for (const auto& [name, value] : loss.terms) terms[name] += value / count;
  }
  if (count > 1) total = total * (1.0 / count);
  for (size_t i = 1; i < hands.size(); ++i) {
    LossInputs own;
    own.offsets = &hands[i].state.offsets;
    own.decoded_rows = hands[i].state.decoded_rows;
    for (auto& component : hands[i].hand->components) component->prepare_loss(hands[i].ctx, own);
    const LossResult loss = objective_->pose_terms(own);
    total = total + loss.total;
    for (const auto& [name, value] : loss.terms) terms[name] += value;
  }
  const auto add_penalties = [&](std::vector<std::unique_ptr<TrainingComponent>>& components,
                                 const EntryContext& part) {
    for (auto& component : components) {
      std::map<std::string, torch::Tensor> penalties;
      component->add_penalties(part, penalties);
      for (const auto& [name, penalty] : penalties) {
        terms[name] += penalty.item<double>();
        total = total + penalty;
      }
    }
  };
  for (HandEntry& h : hands) add_penalties(h.hand->components, h.ctx);
  add_penalties(components_, ctx);
  return total;
}

Trainer::EntryOutcome Trainer::train_entry(int64_t entry, bool diagnostics, StepResult& result) {
  const auto t0 = Clock::now();
  std::vector<ViewTarget> targets;
  std::vector<HandEntry> hands;
  EntryContext ctx = start_entry(entry, targets, result, hands);
  const auto t1 = Clock::now();
  render_entry(ctx, hands);
  const auto t2 = Clock::now();
  std::map<std::string, double> terms;
  const torch::Tensor total = entry_loss(ctx, hands, targets, terms);
  if (entry == 0) result.consistency_weight = ctx.consistency_weight;
  for (const auto& [name, value] : terms) result.terms[name] += value / ctx.entries;
  if (diagnostics) {
    // On the steps run() logs (each value is a reduction and a sync; no need on every step).
    for (HandEntry& h : hands) {
      std::map<std::string, double> values;
      decoder_diagnostics(*h.hand->avatar, h.state, values);
      for (auto& component : h.hand->components) component->diagnostics(h.ctx, values);
      const std::string prefix = h.hand->section.empty() ? "" : h.hand->section + "_";
      for (const auto& [name, value] : values) result.diagnostics[prefix + name] = value;
    }
    for (auto& component : components_) component->diagnostics(ctx, result.diagnostics);
  }
  const auto t3 = Clock::now();

  // The step's loss is the mean over its entries: each entry's gradients arrive scaled by 1/entries.
  (ctx.entries == 1 ? total : total * (1.0 / ctx.entries)).backward();
  const auto t4 = Clock::now();

  EntryOutcome outcome;
  outcome.views = static_cast<int64_t>(ctx.views.size());
  outcome.loss = total.item<double>();
  {
    torch::NoGradGuard no_grad;
    // Capped: a crop rendered exactly (mse 0, +inf dB) would make the running average infinite.
    constexpr double kMaxStepPsnr = 99.0;
    for (int64_t k = 0; k < outcome.views; ++k) {
      const double mse = (ctx.views[k].image.detach() - targets[k].target).pow(2).mean().item<double>();
      outcome.psnr += std::min(psnr_from_mse(mse), kMaxStepPsnr) / outcome.views;
    }
  }
  for (HandEntry& h : hands)
    for (auto& component : h.hand->components) component->after_backward(h.ctx);
  for (auto& component : components_) component->after_backward(ctx);
  result.times.data_ms += ms_between(t0, t1);
  result.times.forward_ms += ms_between(t1, t2);
  result.times.losses_ms += ms_between(t2, t3);
  result.times.backward_ms += ms_between(t3, t4);
  return outcome;
}

bool Trainer::reduce_across_ranks(EntryOutcome& sums, bool finite, std::map<std::string, double>& terms) {
  // One all-reduce of named slots: each parameter's gradient and whether this rank has one, the
  // components' slots, loss, PSNR, "not finite here", "stop requested here" and each loss term
  // with its presence.
  ReduceSlots slots;
  const auto grad_slot = [](const AdamGroup& group, size_t i) {
    return "grad/" + group.name + "/" + std::to_string(i);
  };
  // Each hand's parameters and components in its own scope; the shared optimiser's groups and
  // the shared components' slots have names of their own.
  const auto each_scope = [&](const auto& f) {
    for (HandSlot& hand : hands_) {
      slots.set_scope(hand.section.empty() ? "" : hand.section + "/");
      f(*hand.optimizer, hand.components);
    }
    slots.set_scope("");
    f(*optimizer_, components_);
  };
  each_scope([&](Adam& adam, auto& components) {
    for (auto& group : adam.groups())
      for (size_t i = 0; i < group.params.size(); ++i) {
        const torch::Tensor& p = *group.params[i];
        const bool has = p.grad().defined();
        slots.add(grad_slot(group, i), has ? p.grad() : torch::zeros(p.sizes()));
        slots.add_scalar(grad_slot(group, i) + "/present", has ? 1 : 0);
      }
    for (const auto& component : components) component->contribute(slots);
  });
  slots.add_scalar("loss", sums.loss);
  slots.add_scalar("psnr", sums.psnr);
  slots.add_scalar("not_finite", finite ? 0 : 1);
  slots.add_scalar("stop", StopSignal::requested() ? 1 : 0);
  // The loss terms (a term this rank lacks adds 0 and no presence), so that metrics.csv logs the
  // mean over every rank's views, as one process with their batch would.
  for (const char* name : kReducedTerms) {
    const auto it = terms.find(name);
    slots.add_scalar(std::string("term/") + name, it == terms.end() ? 0.0 : it->second);
    slots.add_scalar(std::string("term/") + name + "/present", it == terms.end() ? 0 : 1);
  }
  slots.all_reduce(*group_);

  sums.loss = slots.scalar("loss");
  sums.psnr = slots.scalar("psnr");
  if (slots.scalar("stop") > 0) stop_agreed_ = true;
  const bool all_finite = slots.scalar("not_finite") == 0 && slots.all_finite();
  const double inverse_ranks = 1.0 / group_->world_size();
  for (const char* name : kReducedTerms) {
    if (slots.scalar(std::string("term/") + name + "/present") > 0)
      terms[name] = slots.scalar(std::string("term/") + name) * inverse_ranks;
    else
      terms.erase(name);
  }
  each_scope([&](Adam& adam, auto& components) {
    for (auto& group : adam.groups())
      for (size_t i = 0; i < group.params.size(); ++i) {
        torch::Tensor& p = *group.params[i];
        if (slots.scalar(grad_slot(group, i) + "/present") > 0)
          p.mutable_grad() = (slots.get(grad_slot(group, i)) * inverse_ranks).clone();
        else
          p.mutable_grad() = torch::Tensor();
      }
    for (auto& component : components) component->receive(slots, inverse_ranks);
  });
  return all_finite;
}

template <class F>
auto Trainer::naming_out_of_memory(const std::string& when, F&& f) {
  try {
    return f();
  } catch (const std::exception& e) {
    if (!is_out_of_memory(e)) throw;
    throw out_of_memory_error(e, when, gaussian_count(), last_checkpoint_);
  }
}

StepResult Trainer::step() {
  return naming_out_of_memory("at step " + std::to_string(iteration_ + 1), [&] { return take_step(); });
}

StepResult Trainer::take_step() {
  StepResult result;
  const int64_t total = config_.train.iterations;
  const int64_t entries = config_.train.batch_size;
  {
    std::vector<int64_t> ahead;
    for (int k = 1; k <= kPrefetchAhead; ++k)
      for (int64_t e = 0; e < entries; ++e)
        for (const FrameInfo* frame :
             entry_order_->frames_for((iteration_ + k) * entries_per_step() + first_entry() + e))
          ahead.push_back(frame->index);
    // Restores this epoch's order.
    entry_order_->frames_for(iteration_ * entries_per_step() + first_entry());
    capture_->prefetch(ahead);
  }
  const bool diagnostics = (iteration_ + 1) % config_.train.log_every == 0;
  EntryOutcome sums;  // loss and PSNR summed over this rank's entries
  bool finite = true;
  for (int64_t e = 0; e < entries; ++e) {
    const EntryOutcome o = train_entry(e, diagnostics && e == 0, result);
    finite = finite && std::isfinite(o.loss);
    sums.loss += o.loss;
    sums.psnr += o.psnr;
    views_rendered_ += o.views;
  }
  const auto t4 = Clock::now();

  if (group_) {
    finite = reduce_across_ranks(sums, finite, result.terms);
  } else {
    for (Adam* adam : optimizers())
      for (auto& group : adam->groups())
        for (auto* p : group.params)
          if (finite && p->grad().defined() && !torch::isfinite(p->grad()).all().item<bool>())
            finite = false;
    // Data parallel: the all-reduce's check covers the components.
    for_each_part([&](auto& components, const std::string&) {
      for (const auto& component : components)
        if (finite && !component->finite()) finite = false;
    });
  }
  result.loss = sums.loss / entries_per_step();
  result.psnr = sums.psnr / entries_per_step();
  if (!finite) {
    for (Adam* adam : optimizers()) adam->zero_grad();
    for_each_part([](auto& components, const std::string&) {
      for (auto& component : components) component->after_skipped_step();
    });
    ++skipped_total_;
    ++bad_in_a_row_;
    result.skipped = true;
    if (is_root())
      spdlog::warn("step {}: non-finite loss or gradient, step skipped ({} in a row)", iteration_ + 1,
                   bad_in_a_row_);
    ++iteration_;
    if (bad_in_a_row_ >= config_.train.max_bad_steps) {
      // Agreed on every rank (the finiteness is): rank 0 reloads, the others take its state.
      result.rolled_back = is_root() ? rollback() : true;
      if (group_) synchronize_state(/*keep_own_state=*/false);
    }
  } else {
    bad_in_a_row_ = 0;
    for (Adam* adam : optimizers()) {
      adam->step(iteration_, total);
      adam->zero_grad();
    }
    ++iteration_;
    bool may_change = false;
    std::vector<int64_t> before;
    for (HandSlot& hand : hands_) {
      for (const auto& component : hand.components)
        may_change = component->may_change_gaussians(iteration_) || may_change;
      before.push_back(hand.avatar->gaussians().size());
    }
    const auto after_step = [&](auto& components, Avatar& avatar, Adam& adam) {
      StepContext step_context;
      step_context.iteration = iteration_;
      step_context.avatar = &avatar;
      step_context.optimizer = &adam;
      step_context.is_root = is_root();
      step_context.seed = static_cast<uint64_t>(config_.train.seed);
      for (auto& component : components) component->after_step(step_context);
    };
    for (HandSlot& hand : hands_) after_step(hand.components, *hand.avatar, *hand.optimizer);
    after_step(components_, *hands_.front().avatar, *optimizer_);
    if (may_change) {
      if (group_) synchronize_state(/*keep_own_state=*/true);  // rank 0 decided: every rank takes it
      for (size_t i = 0; i < hands_.size(); ++i) {
        const int64_t now = hands_[i].avatar->gaussians().size();
        if (now == before[i]) continue;
        for (auto& component : hands_[i].components) component->gaussians_changed();
        if (is_root())
          spdlog::debug("densify at step {}: {} hand {} -> {} Gaussians", iteration_,
                        hand_name(hands_[i].side), before[i], now);
      }
    }
    running_psnr_ = running_psnr_ == 0 ? result.psnr : 0.95 * running_psnr_ + 0.05 * result.psnr;
  }
  result.iteration = iteration_;
  result.times.optimizer_ms = ms_between(t4, Clock::now());
  return result;
}

void Trainer::synchronize_state(bool keep_own_state) {
  std::string bytes;
  if (group_->is_root()) bytes = checkpoint_bytes(make_checkpoint());
  group_->broadcast_bytes(bytes);
  if (group_->is_root()) return;
  const std::string source = "rank 0's state";
  load_from(checkpoint_from_bytes(bytes, source), source, /*allow_changed_data=*/false,
            keep_own_state);
}

bool Trainer::rollback() {
  const auto files = list_checkpoints(run_dir_);
  require(!files.empty() || !initial_state_.empty(),
          "training diverged before the first checkpoint was written");
  require(rollbacks_ < kMaxRollbacks,
          "training diverged: " + std::to_string(rollbacks_) +
              " rollbacks did not help; lower train.lr.* or check the data");
  const double scale = hands_.front().optimizer->lr_scale() * config_.train.rollback_lr_factor;
  const int64_t rollbacks = rollbacks_ + 1;
  const int64_t skipped = skipped_total_;
  const auto restore = [&](const Checkpoint& checkpoint, const std::string& source) {
    // A run resumed with --resume-changing-data may roll back to a checkpoint from before the change.
    load_from(checkpoint, source, accepted_changed_data_);
    for (Adam* adam : optimizers()) adam->set_lr_scale(scale);
    rollbacks_ = rollbacks;
    skipped_total_ = skipped;
    bad_in_a_row_ = 0;
    spdlog::warn("rolled back to {} (step {}), learning rates x{:.3g}", source, iteration_, scale);
  };
  for (const auto& file : files) {
    try {
      restore(load_checkpoint(file), file);
      return true;
    } catch (const Error& e) {
      spdlog::warn("{}", e.what());
    }
  }
  if (!initial_state_.empty()) {
    const std::string source = "the run's initial state";
    restore(checkpoint_from_bytes(initial_state_, source), source);
    return true;
  }
  throw Error("training diverged and no checkpoint in " + run_dir_ + "/checkpoints could be loaded");
}

Checkpoint Trainer::make_checkpoint() {
  Checkpoint ckpt;
  ckpt.meta["format"] = "handscs-checkpoint";
  ckpt.meta["version"] = kCheckpointVersion;
  ckpt.meta["iteration"] = iteration_;
  ckpt.meta["config"] = config_to_json(config_);
  ckpt.meta["skipped_steps"] = skipped_total_;
  ckpt.meta["rollbacks"] = rollbacks_;
  ckpt.meta["running_psnr"] = running_psnr_;
  ckpt.meta["elapsed_seconds"] = elapsed_seconds_;
  ckpt.meta["adam_steps"] = hands_.front().optimizer->steps();
  ckpt.meta["lr_scale"] = hands_.front().optimizer->lr_scale();
  ckpt.meta[kCaptureIdentityKey] = capture_identity_.to_json();
  ckpt.meta[kPlacementKey] = placement_;
  // The first hand's state as a one-hand run writes it, the second hand's in its section.
  for (HandSlot& hand : hands_) {
    Checkpoint part;
    Checkpoint& into = hand.section.empty() ? ckpt : part;
    store_avatar(*hand.avatar, into);
    hand.optimizer->save(into);
    for (const auto& component : hand.components) component->save(into, iteration_);
    if (!hand.section.empty()) add_section(ckpt, hand.section, std::move(part));
  }
  optimizer_->save(ckpt);
  for (const auto& component : components_) component->save(ckpt, iteration_);
  return ckpt;
}

void Trainer::load_from(const Checkpoint& ckpt, const std::string& source, bool allow_changed_data,
                        bool keep_own_state) {
  check_checkpoint_meta(ckpt.meta, source);
  RunConfig stored;
  config_from_json(ckpt.meta.at("config"), source + kStoredConfig, stored);
  const auto changes = experiment_differences(stored, config_);
  if (!changes.empty()) {
    std::string listed;
    for (const auto& line : changes) listed += "\n  " + line;
    const std::string text = source + ": the config changes what the run trains and tests on "
                                      "(checkpoint -> given):" + listed;
    // Not a damaged file: an older checkpoint of the run would differ the same way.
    if (!allow_changed_data)
      throw ExperimentChanged(text + "\nresume with the run's data settings, or pass "
                                     "--resume-changing-data if you mean it (its scores then "
                                     "mix two experiments)");
    spdlog::warn("{}\ncontinuing as asked (--resume-changing-data)", text);
  }
  if (const auto it = ckpt.meta.find(kCaptureIdentityKey); it != ckpt.meta.end()) {
    const auto stored_identity = CaptureIdentity::from_json(*it, source + ": " + kCaptureIdentityKey);
    const auto differences = identity_differences(stored_identity, capture_identity_);
    if (!differences.empty()) {
      const std::string text = source + ": the frames " + config_.data.root + " gives differ from those the " +
                               "run trained on (" + join(differences, "; ") + "): another capture, or a " +
                               "data setting that selects other frames";
      if (!allow_changed_data)
        throw ExperimentChanged(text + "\nresume on the run's capture, or pass --resume-changing-data "
                                       "if you mean it (its scores then mix two experiments)");
      spdlog::warn("{}\ncontinuing as asked (--resume-changing-data)", text);
    }
  }
  if (config_to_json(stored.model) != config_to_json(config_.model)) {
    std::string differences;
    for (const auto& line :
         json_differences(config_to_json(stored.model), config_to_json(config_.model), "model"))
      differences += "\n  " + line;
    throw Error(source + ": its model differs from the config given (checkpoint -> given):" +
                differences + "\nresume with the checkpoint's model settings");
  }
  LoadContext context;
  context.source = source;
  context.iteration = ckpt.meta.at("iteration").get<int64_t>();
  context.data_parallel_root = group_ && group_->is_root();
  context.keep_own_state = keep_own_state;
  // The avatars and components first (densification may have changed the Gaussian counts), then
  // the optimisers built on them.
  std::vector<Checkpoint> sections;
  sections.reserve(hands_.size());
  for (HandSlot& hand : hands_) {
    if (!hand.section.empty() && !ckpt.meta.contains(hand.section))
      throw Error(source + ": checkpoint lacks the " + hand.section + " hand (data.hand is " +
                  hand_name(config_.data.hand) + ")");
    sections.push_back(hand.section.empty() ? Checkpoint{} : checkpoint_section(ckpt, hand.section));
    const Checkpoint& own = hand.section.empty() ? ckpt : sections.back();
    hand.avatar = std::make_unique<Avatar>(
        restore_avatar(own, config_.model, avatar_rig(config_, hand.side), source));
    context.avatar = hand.avatar.get();
    for (auto& component : hand.components) component->load(own, context);
  }
  share_decoders();  // the first hand's, restored; the second's copy of them is dropped
  context.avatar = hands_.front().avatar.get();
  for (auto& component : components_) component->load(ckpt, context);
  build_optimizer();
  const auto fresh_groups = [](const auto& components) {
    std::vector<std::string> groups;  // optimiser state the components start afresh
    for (const auto& component : components)
      for (const std::string& group : component->fresh_optimizer_groups()) groups.push_back(group);
    return groups;
  };
  for (size_t i = 0; i < hands_.size(); ++i) {
    const Checkpoint& own = hands_[i].section.empty() ? ckpt : sections[i];
    hands_[i].optimizer->load(own, source, fresh_groups(hands_[i].components));
  }
  optimizer_->load(ckpt, source, fresh_groups(components_));
  for (Adam* adam : optimizers()) {
    adam->set_steps(ckpt.meta.at("adam_steps").get<int64_t>());
    adam->set_lr_scale(ckpt.meta.at("lr_scale").get<double>());
  }
  iteration_ = context.iteration;
  skipped_total_ = ckpt.meta.value("skipped_steps", int64_t{0});
  rollbacks_ = ckpt.meta.value("rollbacks", int64_t{0});
  running_psnr_ = ckpt.meta.value("running_psnr", 0.0);
  elapsed_seconds_ = ckpt.meta.value("elapsed_seconds", 0.0);
  bad_in_a_row_ = 0;
}

std::string Trainer::save_checkpoint() {
  return naming_out_of_memory("saving the checkpoint of step " + std::to_string(iteration_),
                              [&] { return write_checkpoint(); });
}

std::string Trainer::write_checkpoint() {
  write_run_files();
  ensure_directory(run_dir_ + "/checkpoints");  // --overwrite set the earlier run's folder aside
  const std::string path = run_dir_ + "/checkpoints/" + checkpoint_name(iteration_);
  handscs::save_checkpoint(path, make_checkpoint());
  last_checkpoint_ = path;
  const auto files = list_checkpoints(run_dir_);
  const auto kept = static_cast<size_t>(config_.train.keep_checkpoints);
  if (kept > 0)
    for (size_t i = kept; i < files.size(); ++i) std::filesystem::remove(files[i]);
  if (first_checkpoint_hook_) std::exchange(first_checkpoint_hook_, nullptr)();
  return path;
}

bool Trainer::resume(bool allow_changed_data) {
  const auto files = list_checkpoints(run_dir_);
  std::string reasons;
  for (size_t k = 0; k < files.size(); ++k) {
    const std::string& file = files[k];
    try {
      load_from(load_checkpoint(file), file, allow_changed_data);
      accepted_changed_data_ = allow_changed_data;
      last_checkpoint_ = file;
      spdlog::info("resumed from {} at step {}", file, iteration_);
      // The newer files that could not be resumed are set aside, not deleted (the user may want to
      // look at them), and no longer count among the run's checkpoints: keeping the newest two
      // would otherwise keep them and delete the valid one resumed from.
      for (size_t newer = 0; newer < k; ++newer) {
        std::error_code ec;
        std::filesystem::rename(files[newer], files[newer] + ".unreadable", ec);
        if (ec)
          throw Error(files[newer] + ": cannot set it aside as .unreadable (" + ec.message() + ")");
        spdlog::warn("{}: set aside as {}.unreadable", files[newer], files[newer]);
      }
      truncate_metrics_log(run_dir_ + "/metrics.csv", iteration_);
      return true;
    } catch (const ExperimentChanged&) {
      throw;
    } catch (const Error& e) {
      spdlog::warn("cannot resume from {}; trying an older checkpoint", e.what());
      reasons += "\n" + std::string(e.what());
    }
  }
  if (!files.empty())
    throw Error(run_dir_ + (files.size() == 1 ? ": its one checkpoint cannot"
                                              : ": none of its " + std::to_string(files.size()) + " checkpoints can") +
                " be resumed; nothing was changed:" + reasons);
  truncate_metrics_log(run_dir_ + "/metrics.csv", 0);
  return false;
}

void Trainer::validate() {
  naming_out_of_memory("validating at step " + std::to_string(iteration_), [&] { render_validation(); });
}

void Trainer::render_validation() {
  const auto& frames = capture_->test().empty() ? capture_->train() : capture_->test();
  const FrameInfo& frame = frames.front();
  c10::InferenceMode guard;
  FrameSample sample = capture_->load(frame, /*full_image=*/true);
  std::vector<AvatarState> states;
  states.reserve(hands_.size());
  std::vector<const PosedGaussians*> posed;
  for (HandSlot& hand : hands_) {
    if (hands_.size() > 1 && !frame.hand(hand.side)) continue;
    const FrameInfo own = frame_of_hand(frame, hand.side);
    states.push_back(hand.avatar->pose(float_vector(own.pose), float_vector(own.shape),
                                       float_vector(own.trans)));
    posed.push_back(&states.back().posed);
  }
  const RasterOutput render = render_posed(join_posed(posed), sample.camera, RasterSettings{});
  const auto rgb = camera_color_ ? camera_color_->as_recorded(frame.camera_id, render, {0, 0, 0})
                                 : render.rgb;
  const auto mask = sample.mask.to(torch::kFloat32).unsqueeze(2);
  const auto gt = sample.image.to(torch::kFloat32).div(255.0) * mask;
  const auto pred = rgb.clamp(0, 1);
  // Labelled: render | ground truth | error, with the step, the view and its PSNR written above.
  const double psnr_db = psnr(hwc_to_bchw(pred), hwc_to_bchw(gt)).item<double>();
  char caption[256];
  std::snprintf(caption, sizeof(caption), "step %lld  %s  camera %s  PSNR %.2f dB",
                static_cast<long long>(iteration_), frame.file_name.c_str(),
                frame.camera_id.c_str(), psnr_db);
  ensure_directory(run_dir_ + "/validation");
  char name[64];
  std::snprintf(name, sizeof(name), "/validation/step_%08lld.png", static_cast<long long>(iteration_));
  write_png(run_dir_ + name, comparison_panel(pred, gt, caption));
}

void Trainer::log_step(const StepResult& r) {
  write_run_files();
  std::map<std::string, std::string> cells;  // by column name; the file's columns give the order
  const auto set = [&cells](const std::string& column, auto value) {
    std::ostringstream text;
    text << value;
    cells[column] = text.str();
  };
  set("iteration", r.iteration);
  set("seconds", elapsed_seconds_);
  set("loss", r.loss);
  for (const auto& [term, value] : r.terms) set(term, value);
  set("psnr", r.psnr);
  set("gaussians", gaussian_count());
  set("skipped", skipped_total_);
  set("rollbacks", rollbacks_);
  set("lr_scale", hands_.front().optimizer->lr_scale());
  set("data_ms", r.times.data_ms);
  set("forward_ms", r.times.forward_ms);
  set("losses_ms", r.times.losses_ms);
  set("backward_ms", r.times.backward_ms);
  set("optimizer_ms", r.times.optimizer_ms);
  for (const auto& [column, value] : r.diagnostics) set(column, value);  // cells go by name
  std::vector<std::string> row;
  for (const std::string& column : metrics_columns_) {
    auto it = cells.find(column);
    row.push_back(it == cells.end() ? std::string() : it->second);
  }
  std::ofstream out(run_dir_ + "/metrics.csv", std::ios::app);
  out << join(row, ",") << "\n";
}

int64_t Trainer::gaussian_count() const {
  int64_t count = 0;
  for (const HandSlot& hand : hands_) count += hand.avatar->gaussians().size();
  return count;
}

TrainMemoryEstimate Trainer::memory_estimate() {
  int64_t largest = 0;  // a resumed run's hands start from their checkpoint's counts
  for (const HandSlot& hand : hands_)
    largest = std::max<int64_t>(largest, hand.avatar->gaussians().size());
  return estimate_train_memory(config_, train_memory_inputs(*capture_, largest, hand_count()));
}

void Trainer::gather_components() {
  for_each_part([&](auto& components, const std::string&) {
    for (auto& component : components) component->gather(*group_, iteration_);
  });
}

TrainSummary Trainer::run() {
  const StopSignal stop_signal;  // Ctrl-C, SIGTERM or SIGHUP: save a checkpoint and end
  stop_agreed_ = false;
  // Every rank starts from rank 0's state: its initialisation, or the checkpoint it resumed.
  if (group_) synchronize_state(/*keep_own_state=*/false);
  const bool root = is_root();
  const auto start = Clock::now();
  const double elapsed_before = elapsed_seconds_;
  const int64_t first_iteration = iteration_;
  const int64_t views_before = views_rendered_;
  const CommunicationStats communication_before = group_ ? group_->stats() : CommunicationStats{};
  // The state a rollback before the first checkpoint returns to, kept in memory: nothing is written
  // before the first logged step or checkpoint, so a run that stops at its first steps with a user
  // error (a crop too small for the image losses) leaves the folder as it was.
  if (root && last_checkpoint_.empty())
    naming_out_of_memory("before step " + std::to_string(iteration_ + 1),
                         [&] { initial_state_ = checkpoint_bytes(make_checkpoint()); });
  const int64_t total = config_.train.iterations;
  std::unique_ptr<ProgressBar> bar;  // rank 0 reports for all
  if (root) bar = std::make_unique<ProgressBar>("train", total);
  char status[160] = "";
  int64_t gathered_at = -1;  // the same on every rank, so all decide the final gather alike
  while (iteration_ < total && !stop_requested()) {
    const StepResult r = step();
    elapsed_seconds_ = elapsed_before + ms_between(start, Clock::now()) / 1000.0;
    const bool checkpoint_due = iteration_ % config_.train.checkpoint_every == 0;
    if (group_ && checkpoint_due) {  // every rank takes part
      gather_components();
      gathered_at = iteration_;
    }
    if (!root) continue;
    std::snprintf(status, sizeof(status), "loss %.4f psnr %.2f (avg %.2f) N %lld%s", r.loss, r.psnr,
                  running_psnr_, static_cast<long long>(gaussian_count()),
                  skipped_total_ ? (" skipped " + std::to_string(skipped_total_)).c_str() : "");
    bar->update(iteration_, status);
    if (iteration_ % config_.train.log_every == 0 || r.skipped) log_step(r);
    if (checkpoint_due) save_checkpoint();
    if (config_.train.validate_every > 0 && iteration_ % config_.train.validate_every == 0)
      validate();
  }
  const bool interrupted = stop_requested() && iteration_ < total;
  // For the final checkpoint (every rank gets here), unless the loop's last step just gathered.
  if (group_ && gathered_at != iteration_) gather_components();
  if (root) {
    if (last_checkpoint_.find(checkpoint_name(iteration_)) == std::string::npos) save_checkpoint();
    for_each_part([&](auto& components, const std::string& section) {
      // The second hand's files go in a folder of its own.
      const std::string folder = section.empty() ? run_dir_ : run_dir_ + "/" + section;
      if (folder != run_dir_ && config_.train.pose_refine.enabled) ensure_directory(folder);
      for (const auto& component : components) component->finish(folder);
    });
    bar->finish(status);
  }
  if (interrupted && root)
    spdlog::warn("interrupted at step {}: checkpoint {} saved; continue with --resume", iteration_,
                 last_checkpoint_);
  TrainSummary summary;
  summary.iterations = iteration_;
  summary.seconds = ms_between(start, Clock::now()) / 1000.0;
  summary.skipped_steps = skipped_total_;
  summary.rollbacks = rollbacks_;
  summary.gaussians = gaussian_count();
  summary.interrupted = interrupted;
  summary.checkpoint = last_checkpoint_;
  summary.steps = iteration_ - first_iteration;
  // Every rank renders as many views per step (ranks differ at most where a pose has fewer
  // cameras than train.views_per_pose).
  summary.views = (views_rendered_ - views_before) * (group_ ? group_->world_size() : 1);
  if (group_) {
    const auto& now = group_->stats();
    summary.communication = {now.calls - communication_before.calls,
                             now.bytes - communication_before.bytes,
                             now.seconds - communication_before.seconds};
  }
  return summary;
}

}  // namespace handscs
