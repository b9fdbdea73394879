#include "train/trainer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
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
#include "io/png.h"
#include "metrics/comparison_panel.h"
#include "metrics/image_tensor.h"
#include "metrics/psnr.h"
#include "render/projected_radii.h"
#include "run/avatar_state_io.h"
#include "run/checkpoint_meta.h"
#include "train/consistency.h"
#include "train/descriptor_tree.h"
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
// ... then, with train.cull only (a log without it gains the column when a resume turns the cull
// on, and keeps it, empty, when a resume turns it off: prepare_metrics_log).
constexpr const char* kCullColumn = "decoded_fraction";
// The loss terms a step reports (StepResult::terms): data parallel sums them across ranks.
const char* kReducedTerms[] = {"rgb",         "mask",       "ssim",        "lpips", "reg",
                               "consistency", "pose_refine", "camera_color"};
// The optimiser group of the per-camera colour transforms (train.camera_color).
constexpr const char* kCameraColorGroup = "camera_color";

// train.cull: [N] bool, true for the Gaussians the pose decoded; undefined when it decoded all.
torch::Tensor decoded_mask(const AvatarState& state) {
  if (!state.decoded_rows.defined()) return {};
  return torch::zeros({state.posed.means.size(0)}, torch::kBool).index_fill_(0, state.decoded_rows, true);
}

// Checkpoint names of the inter-pose chain of the step's view `view` (view 0 keeps the names of
// the single-view format, so older checkpoints resume).
std::string chain_prefix(int64_t view) {
  return view == 0 ? "consistency/" : "consistency/view" + std::to_string(view) + "/";
}

}  // namespace

Trainer::Trainer(const RunConfig& config, const std::string& run_dir, ProcessGroup* group)
    : config_(config), run_dir_(run_dir), group_(group) {
  validate_run_config(config_, "config");
  if (group_ && group_->world_size() == 1) group_ = nullptr;
  ensure_directory(run_dir_);
  ensure_directory(run_dir_ + "/checkpoints");
  if (is_root()) remove_stale_temporaries(run_dir_);
  prev_chains_.resize(config_.train.batch_size);
  next_chains_.resize(config_.train.batch_size);

  capture_ = std::make_unique<Capture>(Capture::open(config_.data, run_dir_ + "/cache"));
  require(!capture_->train().empty(),
          "data: the capture has no training frames (check data.root, split, capture, cameras)");
  if (config_.train.views_per_pose > 1) {
    std::map<int, std::vector<int64_t>> by_pose;  // ordered: the same grouping on every run
    const auto& frames = capture_->train();
    for (size_t k = 0; k < frames.size(); ++k) by_pose[frames[k].pose_index].push_back(k);
    for (auto& [pose, positions] : by_pose) train_poses_.push_back(std::move(positions));
  }
  if (is_root()) {
    spdlog::info("capture: {} training and {} test frames, {} poses, {} cameras",
               capture_->train().size(), capture_->test().size(), capture_->num_poses(),
               capture_->cameras().size());
    const std::string batch_warning =
        batch_size_warning(config_.train.batch_size, group_ ? group_->world_size() : 1,
                           static_cast<int64_t>(capture_->train().size()));
    if (!batch_warning.empty()) spdlog::warn("{}", batch_warning);
  }

  avatar_ = std::make_unique<Avatar>(config_.model, load_rig_source(avatar_rig_source(config_)));
  camera_colors_ = make_camera_colors();
  build_optimizer();
  if (config_.train.pose_refine.enabled)
    pose_corrections_ =
        std::make_unique<PoseCorrections>(capture_->num_poses(), config_.train.pose_refine);
  densifier_ = std::make_unique<Densifier>(config_.train.densify);

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
  std::vector<std::string> columns(std::begin(kDiagnosticColumns), std::end(kDiagnosticColumns));
  if (config_.train.cull.enabled) columns.push_back(kCullColumn);
  return columns;
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

std::unique_ptr<CameraColors> Trainer::make_camera_colors() const {
  if (config_.train.camera_color == TrainConfig::CameraColor::off) return nullptr;
  std::set<std::string> ids;  // sorted: the same rows on every rank and every run
  for (const auto& frame : capture_->train()) ids.insert(frame.camera_id);
  return std::make_unique<CameraColors>(config_.train.camera_color,
                                        std::vector<std::string>(ids.begin(), ids.end()));
}

void Trainer::build_optimizer() {
  const auto& lr = config_.train.lr;
  auto& g = avatar_->gaussians();
  optimizer_ = std::make_unique<Adam>();
  optimizer_->add_group("means", {&g.means}, lr.means, lr.means_final, true);
  optimizer_->add_group("log_scales", {&g.log_scales}, lr.log_scales, lr.log_scales, true);
  optimizer_->add_group("rotations", {&g.rotations}, lr.rotations, lr.rotations, true);
  optimizer_->add_group("colors", {&g.colors}, lr.colors, lr.colors, true);
  optimizer_->add_group("opacity", {&g.opacity_logits}, lr.opacity, lr.opacity, true);
  optimizer_->add_group("embeddings", {&g.embed_geometry, &g.embed_appearance}, lr.embeddings,
                        lr.embeddings, true);
  network_params_.clear();
  auto groups = avatar_->network_parameter_groups();
  size_t total = 0;
  for (auto& [name, params] : groups) total += params.size();
  network_params_.reserve(total);  // pointers into this vector stay valid: no reallocation
  for (auto& [name, params] : groups) {
    std::vector<torch::Tensor*> pointers;
    for (auto& p : params) {
      network_params_.push_back(p);
      pointers.push_back(&network_params_.back());
    }
    if (name == "gates")
      optimizer_->add_group(name, pointers, lr.gates, lr.gates, false);
    else
      optimizer_->add_group(name, pointers, lr.networks, lr.networks_final, false);
  }
  // Last, so that the groups before it (and the all-reduce's layout of them) are as without it.
  if (camera_colors_)
    optimizer_->add_group(kCameraColorGroup, {&camera_colors_->parameters()}, lr.camera_color,
                          lr.camera_color, false);
}

int64_t Trainer::entries_per_step() const {
  return config_.train.batch_size * (group_ ? group_->world_size() : 1);
}

int64_t Trainer::first_entry() const {
  return config_.train.batch_size * (group_ ? group_->rank() : 0);
}

bool Trainer::stop_requested() const { return group_ ? stop_agreed_ : StopSignal::requested(); }

std::vector<const FrameInfo*> Trainer::frames_for(int64_t entry_index) {
  const auto& frames = capture_->train();
  const int64_t per_pose = config_.train.views_per_pose;
  // One frame per entry, or one pose: the epoch runs over frames or over poses.
  const int64_t n = per_pose == 1 ? static_cast<int64_t>(frames.size())
                                  : static_cast<int64_t>(train_poses_.size());
  const int64_t epoch = entry_index / n;
  if (epoch != order_epoch_) {
    order_.resize(n);
    for (int64_t i = 0; i < n; ++i) order_[i] = i;
    // The order is a function of (seed, epoch) alone, so a resumed run sees the same frames.
    std::mt19937_64 rng(static_cast<uint64_t>(config_.train.seed) * 1000003ull + epoch);
    std::shuffle(order_.begin(), order_.end(), rng);
    order_epoch_ = epoch;
  }
  const int64_t picked = order_[entry_index % n];
  if (per_pose == 1) return {&frames[picked]};
  // The pose's cameras in an order of (seed, entry) alone; the first views_per_pose of them.
  std::vector<int64_t> cameras = train_poses_[picked];
  std::mt19937_64 rng(static_cast<uint64_t>(config_.train.seed) * 2000029ull + entry_index);
  std::shuffle(cameras.begin(), cameras.end(), rng);
  cameras.resize(std::min<size_t>(cameras.size(), static_cast<size_t>(per_pose)));
  std::vector<const FrameInfo*> out;
  for (const int64_t k : cameras) out.push_back(&frames[k]);
  return out;
}

std::array<float, 3> Trainer::background_for(int64_t view_index) const {
  if (config_.train.background == TrainConfig::Background::white) return {1, 1, 1};
  if (config_.train.background == TrainConfig::Background::black) return {0, 0, 0};
  std::mt19937_64 rng(static_cast<uint64_t>(config_.train.seed) * 7919ull + view_index);
  std::uniform_real_distribution<float> u(0.f, 1.f);
  return {u(rng), u(rng), u(rng)};
}

torch::Tensor Trainer::consistency_loss(const AvatarState& state, const torch::Tensor& decoded,
                                        const torch::Tensor& rendered_pose, size_t chain, double* pair_weight) {
  const ConsistencyChain& prev = prev_chains_[chain];
  auto& g = avatar_->gaussians();
  const auto& cc = config_.train.consistency;
  auto pose = rendered_pose.detach().to(torch::kFloat32).clone();
  if (!config_.model.flat_hand_mean)
    pose.slice(0, 3, 48) += avatar_->rig().hands_mean.to(torch::kFloat32);
  const auto feature = pose_feature(pose);
  const auto attributes =
      consistency_attributes(state.canonical_means, state.canonical_covariances,
                             state.canonical_colors, g.embed_geometry, g.embed_appearance);
  torch::Tensor loss;
  const double weight = prev.descriptor.defined()
                            ? pose_similarity(feature, prev.pose_feature, cc.delta)
                            : 0.0;
  if (prev.descriptor.defined()) *pair_weight = weight;
  if (prev.descriptor.defined() && prev.descriptor.size(0) == g.size() &&
      weight >= cc.min_weight) {
    torch::Tensor match;
    const bool gemm =
        cc.search == ConsistencyConfig::Search::exact ||
        (cc.search == ConsistencyConfig::Search::automatic && g.size() <= cc.exact_max_gaussians);
    if (gemm) {
      match = correspond_exact(state.descriptor, prev.descriptor);
    } else if (cc.search == ConsistencyConfig::Search::candidates) {
      if (!candidates_.defined() || candidates_.size(0) != g.size() ||
          iteration_ % cc.refresh_every == 0)
        candidates_ = nearest_neighbours(g.means, cc.candidates);
      match = correspond_candidates(state.descriptor, prev.descriptor, candidates_);
    } else {
      // Rows persist between steps (the state is reset on densification): each Gaussian's own
      // previous row is the natural first guess.
      match = DescriptorTree(prev.descriptor).nearest(state.descriptor,
                                                       torch::arange(g.size(), torch::kInt64));
    }
    auto diff = consistency_distances(attributes, prev.attributes.index_select(0, match),
                                      state.canonical_covariances, cc.normalize);
    // train.cull: a pair counts only when both of its Gaussians were decoded (the others carry
    // no offsets at their step).
    if (decoded.defined() || prev.decoded.defined())
      diff = diff.index_select(0, pairs_decoded_at_both_steps(decoded, prev.decoded, match));
    if (diff.numel() > 0)
      loss = weight * (cc.reduction == ConsistencyConfig::Reduction::sum ? diff.sum() : diff.mean());
  }
  // Kept for the next step (M_0 = M_1 on the first step: no loss).
  next_chains_[chain] = {state.descriptor.detach(), attributes.detach(), feature, decoded};
  return loss;
}

// One pose-correction update of a step (pose refinement).
struct Trainer::PoseUpdate {
  int64_t entry = 0;       // the step's entry, over every rank (first_entry() + e)
  int64_t pose_index = 0;  // the training pose whose correction it updates
  torch::Tensor grad;      // [PoseCorrections::kWidth], scaled as the step's mean over entries
};

// What one entry of a step leaves behind after its backward (its gradients are in the parameters).
struct Trainer::EntryOutcome {
  double loss = 0;  // mean over the entry's views, unweighted by the step's entry count
  double psnr = 0;  // mean over the entry's views
  int64_t views = 0;
  Densifier::ViewStatistics densify;  // summed over the views; undefined without densification
  int64_t pose_index = -1;            // pose refinement: the pose whose correction was learned
  torch::Tensor pose_delta;           // ... its correction (holds the gradient); else undefined
};

Trainer::ViewTarget Trainer::load_view(const FrameInfo& frame, int64_t view_index) {
  FrameSample sample = capture_->load(frame);
  empty_masks_->record(frame, !sample.mask.any().item<bool>());
  ViewTarget view;
  view.camera = sample.roi_camera();
  torch::Tensor image = sample.image.to(torch::kFloat32).div_(255.0);  // [h, w, 3]
  view.mask = sample.mask.to(torch::kFloat32);                        // [h, w]
  const double scale = config_.train.resolution_scale;
  if (scale != 1.0) {
    const int w = static_cast<int>(scaled_side(view.camera.width, scale));
    const int h = static_cast<int>(scaled_side(view.camera.height, scale));
    cv::Mat img(image.size(0), image.size(1), CV_32FC3, image.data_ptr<float>());
    cv::Mat msk(view.mask.size(0), view.mask.size(1), CV_32FC1, view.mask.data_ptr<float>());
    cv::Mat img_small, msk_small;
    cv::resize(img, img_small, cv::Size(w, h), 0, 0, cv::INTER_AREA);
    cv::resize(msk, msk_small, cv::Size(w, h), 0, 0, cv::INTER_AREA);
    image = torch::from_blob(img_small.data, {h, w, 3}, torch::kFloat32).clone();
    view.mask = torch::from_blob(msk_small.data, {h, w}, torch::kFloat32).clone();
    view.camera = resample_camera(view.camera, double(w) / view.camera.width, w, h);
  }
  const std::string too_small = scaled_crop_problem(frame, static_cast<int>(image.size(1)),
                                                    static_cast<int>(image.size(0)), scale,
                                                    min_loss_side_);
  if (!too_small.empty()) throw Error(too_small);
  view.background = background_for(view_index);
  const auto bg = torch::tensor({view.background[0], view.background[1], view.background[2]});
  const auto mask3 = view.mask.unsqueeze(2);
  view.target = image * mask3 + bg * (1 - mask3);
  return view;
}

Trainer::EntryOutcome Trainer::train_entry(int64_t entry, bool diagnostics, StepResult& result) {
  EntryOutcome outcome;
  const int64_t entries = config_.train.batch_size;
  const int64_t entry_index = iteration_ * entries_per_step() + first_entry() + entry;
  const auto t0 = Clock::now();
  const std::vector<const FrameInfo*> frames = frames_for(entry_index);
  const FrameInfo& current = *frames.front();  // the pose, shape and translation of them all
  std::vector<ViewTarget> views;
  for (const FrameInfo* frame : frames) result.frames.push_back(frame->index);
  for (size_t k = 0; k < frames.size(); ++k)
    views.push_back(load_view(*frames[k], entry_index * config_.train.views_per_pose +
                                              static_cast<int64_t>(k)));
  const int64_t count = static_cast<int64_t>(views.size());
  outcome.views = count;
  const auto t1 = Clock::now();

  auto& g = avatar_->gaussians();
  const bool densify = config_.train.densify.enabled;
  const bool consistency = config_.train.loss.consistency > 0;
  auto pose = float_vector(current.pose);
  auto trans = float_vector(current.trans);
  CorrectedPose corrected;  // delta undefined without pose refinement
  if (pose_corrections_) {
    const bool learn = iteration_ >= config_.train.pose_refine.start;
    corrected = pose_corrections_->apply(current.pose_index, pose, trans, learn);
    pose = corrected.pose;
    trans = corrected.trans;
  }
  const bool learn_pose = corrected.delta.defined() && corrected.delta.requires_grad();
  // The pose is decoded once; each view rasterises the same posed Gaussians.
  std::optional<FacingCull> cull;
  if (config_.train.cull.enabled) {
    cull.emplace();
    cull->max_cos = config_.train.cull.max_cos;
    for (const auto& view : views) cull->camera_centres.push_back(view.camera.centre());
  }
  const AvatarState state = avatar_->pose(pose, float_vector(current.shape), trans, consistency,
                                          cull ? &*cull : nullptr);
  const torch::Tensor decoded = decoded_mask(state);  // for L_con's pairs and densification
  std::vector<torch::Tensor> probes;
  std::vector<RasterOutput> renders;
  for (const auto& view : views) {
    probes.push_back(densify ? torch::zeros({g.size(), 2}).requires_grad_(true) : torch::Tensor());
    RasterSettings settings;
    settings.background = view.background;
    renders.push_back(render_posed(state.posed, view.camera, settings, probes.back()));
  }
  // train.camera_color: each view as its camera records the avatar's colours.
  std::vector<torch::Tensor> images;
  for (int64_t k = 0; k < count; ++k) {
    const int64_t row = camera_colors_ ? camera_colors_->row(frames[k]->camera_id) : -1;
    images.push_back(row < 0 ? renders[k].rgb
                             : apply_color_transform(renders[k].rgb, renders[k].alpha,
                                                     views[k].background, camera_colors_->matrix(row)));
  }
  const auto t2 = Clock::now();

  double pair_weight = -1;
  torch::Tensor consistency_term;  // one per pose: the same for each of its views
  if (consistency) consistency_term = consistency_loss(state, decoded, pose, entry, &pair_weight);
  if (entry == 0) result.consistency_weight = pair_weight;
  // The entry's loss is the mean over its views (the pose's terms, L_reg and L_con, are the same
  // in each, so they count once).
  torch::Tensor total;
  std::map<std::string, double> terms;
  for (int64_t k = 0; k < count; ++k) {
    LossInputs in;
    in.rgb = images[k];
    in.alpha = renders[k].alpha;
    in.target = views[k].target;
    in.mask = views[k].mask;
    in.offsets = &state.offsets;
    in.decoded_rows = state.decoded_rows;
    in.lpips_step = (iteration_ + 1) % config_.train.loss.lpips_every == 0;
    in.consistency = consistency_term;
    auto loss = objective_->compute(in);
    total = k == 0 ? loss.total : total + loss.total;
    for (const auto& [name, value] : loss.terms) terms[name] += value / count;
  }
  if (count > 1) total = total * (1.0 / count);
  if (learn_pose) {
    const auto penalty = pose_corrections_->penalty(corrected.delta);
    terms["pose_refine"] = penalty.item<double>();
    total = total + penalty;
    outcome.pose_index = current.pose_index;
    outcome.pose_delta = corrected.delta;
  }
  if (camera_colors_) {
    // Once per entry (each entry's gradient is scaled by 1/entries): once per step in all.
    const auto penalty = camera_colors_->penalty(config_.train.loss.camera_color);
    terms["camera_color"] = penalty.item<double>();
    total = total + penalty;
  }
  for (const auto& [name, value] : terms) result.terms[name] += value / entries;
  if (diagnostics) {
    // Whether the decoders do anything: their gates and the mean size of each offset, on the
    // steps run() logs (each is a reduction and a sync; no need on every step).
    torch::NoGradGuard no_grad;
    const auto& decoders = avatar_->decoders();
    result.diagnostics["gate_geometry"] = decoders->geometry->gate.item<double>();
    result.diagnostics["gate_appearance"] = decoders->appearance->gate.item<double>();
    result.diagnostics["gate_fusion"] = decoders->fusion->gate.item<double>();
    for (const auto& [name, norms] : offset_norms(state.offsets)) {
      const auto kept = state.decoded_rows.defined() ? norms.index_select(0, state.decoded_rows) : norms;
      result.diagnostics["offset_" + name] = kept.mean().item<double>();
    }
    if (cull)  // train.cull: the share of Gaussians decoded and rendered
      result.diagnostics[kCullColumn] = state.decoded_fraction();
    if (pose_corrections_)
      for (const auto& [name, value] : pose_corrections_->summary()) result.diagnostics[name] = value;
  }
  const auto t3 = Clock::now();

  // The step's loss is the mean over its entries: each entry's gradients arrive scaled by 1/entries.
  (entries == 1 ? total : total * (1.0 / entries)).backward();
  const auto t4 = Clock::now();

  outcome.loss = total.item<double>();
  {
    torch::NoGradGuard no_grad;
    // Capped: a crop rendered exactly (mse 0, +inf dB) would make the running average infinite.
    constexpr double kMaxStepPsnr = 99.0;
    for (int64_t k = 0; k < count; ++k) {
      const double mse = (images[k].detach() - views[k].target).pow(2).mean().item<double>();
      outcome.psnr += std::min(psnr_from_mse(mse), kMaxStepPsnr) / count;
    }
  }
  if (densify) {
    // The densification threshold is per view: undo the 1/(entries x views) of the means.
    const double weight = double(entries * count);
    // train.cull: a skipped Gaussian counts as seen, with no gradient, by every view whose exact
    // render would have projected it (its un-offset geometry and own opacity): it is on the hand's
    // far side, where the exact render's gradient is that of an occluded Gaussian. Counting it as
    // unseen raised the mean gradient of the back's Gaussians and densified 60% more of them.
    for (int64_t k = 0; k < count; ++k) {
      const auto grad = probes[k].grad().defined() ? probes[k].grad() : torch::zeros_like(probes[k]);
      const auto radii =
          decoded.defined()
              ? torch::where(decoded, renders[k].radii,
                             projected_radii(state.posed.means, state.posed.covariances,
                                             torch::sigmoid(g.opacity_logits), views[k].camera, {}))
              : renders[k].radii;
      const auto s = Densifier::view_statistics(weight == 1 ? grad : grad * weight, radii);
      outcome.densify.grad_norm = k == 0 ? s.grad_norm : outcome.densify.grad_norm + s.grad_norm;
      outcome.densify.visible = k == 0 ? s.visible : outcome.densify.visible + s.visible;
    }
  }
  result.times.data_ms += ms_between(t0, t1);
  result.times.forward_ms += ms_between(t1, t2);
  result.times.losses_ms += ms_between(t2, t3);
  result.times.backward_ms += ms_between(t3, t4);
  return outcome;
}

bool Trainer::reduce_across_ranks(EntryOutcome& sums, bool finite, std::map<std::string, double>& terms,
                                  std::vector<PoseUpdate>& pose_updates) {
  // One buffer, one all-reduce: each parameter's gradient, the densification statistics, the pose
  // updates' slots, per parameter a flag (has a gradient here), then loss, PSNR, "not finite here",
  // "stop requested here" and each loss term with its presence.
  std::vector<torch::Tensor*> params;
  for (auto& group : optimizer_->groups())
    for (auto* p : group.params) params.push_back(p);
  std::vector<torch::Tensor> parts;
  std::vector<float> flags;
  for (auto* p : params) {
    const bool has = p->grad().defined();
    flags.push_back(has ? 1.f : 0.f);
    parts.push_back(has ? p->grad().reshape(-1) : torch::zeros({p->numel()}));
  }
  const bool densify = sums.densify.visible.defined();
  if (densify) {
    parts.push_back(sums.densify.grad_norm);
    parts.push_back(sums.densify.visible);
  }
  // Pose refinement: one slot per entry of the step over every rank (flag, pose index, gradient),
  // this rank's filled and the others' zero, so the sum hands every rank every update (an
  // all-gather by all-reduce). Pose indices are exact in float32 up to 2^24.
  const int64_t slot_width = 2 + PoseCorrections::kWidth;
  const int64_t slots = pose_corrections_ ? entries_per_step() : 0;
  if (slots > 0) {
    auto pose_slots = torch::zeros({slots, slot_width});
    for (const auto& update : pose_updates) {
      pose_slots[update.entry][0] = 1.0;
      pose_slots[update.entry][1] = static_cast<double>(update.pose_index);
      pose_slots[update.entry].slice(0, 2).copy_(update.grad.reshape(-1));
    }
    parts.push_back(pose_slots.reshape(-1));
  }
  parts.push_back(torch::tensor(flags, torch::kFloat32));
  // The loss terms (a term this rank lacks adds 0 and no presence), so that metrics.csv logs the
  // mean over every rank's views, as one process with their batch would.
  std::vector<float> scalar_values = {static_cast<float>(sums.loss), static_cast<float>(sums.psnr),
                                      finite ? 0.f : 1.f, StopSignal::requested() ? 1.f : 0.f};
  for (const char* name : kReducedTerms) {
    const auto it = terms.find(name);
    scalar_values.push_back(it == terms.end() ? 0.f : static_cast<float>(it->second));
    scalar_values.push_back(it == terms.end() ? 0.f : 1.f);
  }
  const auto scalar_count = static_cast<int64_t>(scalar_values.size());
  parts.push_back(torch::tensor(scalar_values, torch::kFloat32));
  auto buffer = torch::cat(parts).to(torch::kFloat32).contiguous();
  group_->all_reduce_sum(buffer);

  const int64_t tail = static_cast<int64_t>(flags.size()) + scalar_count;
  const auto summed_flags = buffer.slice(0, buffer.numel() - tail, buffer.numel() - scalar_count);
  const auto scalars = buffer.slice(0, buffer.numel() - scalar_count).contiguous();
  const float* scalar = scalars.data_ptr<float>();
  sums.loss = scalar[0];
  sums.psnr = scalar[1];
  if (scalar[3] > 0) stop_agreed_ = true;
  const bool all_finite = scalar[2] == 0 && torch::isfinite(buffer).all().item<bool>();
  const double inverse_ranks = 1.0 / group_->world_size();
  for (size_t k = 0; k < std::size(kReducedTerms); ++k) {
    if (scalar[5 + 2 * k] > 0)
      terms[kReducedTerms[k]] = scalar[4 + 2 * k] * inverse_ranks;
    else
      terms.erase(kReducedTerms[k]);
  }
  int64_t offset = 0;
  for (size_t i = 0; i < params.size(); ++i) {
    auto* p = params[i];
    const int64_t n = p->numel();
    if (summed_flags[static_cast<int64_t>(i)].item<float>() > 0)
      p->mutable_grad() = (buffer.slice(0, offset, offset + n) * inverse_ranks).view(p->sizes()).clone();
    else
      p->mutable_grad() = torch::Tensor();
    offset += n;
  }
  if (densify) {
    const int64_t n = sums.densify.visible.numel();
    sums.densify.grad_norm = buffer.slice(0, offset, offset + n).clone();
    sums.densify.visible = buffer.slice(0, offset + n, offset + 2 * n).clone();
    offset += 2 * n;
  }
  if (slots > 0) {
    // Gradients scaled as the parameters' (the mean over every rank's entries), in entry order.
    const auto pose_slots = buffer.slice(0, offset, offset + slots * slot_width).view({slots, slot_width});
    pose_updates.clear();
    for (int64_t entry = 0; entry < slots; ++entry)
      if (pose_slots[entry][0].item<float>() > 0)
        pose_updates.push_back({entry, static_cast<int64_t>(pose_slots[entry][1].item<float>()),
                                pose_slots[entry].slice(0, 2) * inverse_ranks});
  }
  return all_finite;
}

StepResult Trainer::step() {
  StepResult result;
  const int64_t total = config_.train.iterations;
  const int64_t entries = config_.train.batch_size;
  {
    std::vector<int64_t> ahead;
    for (int k = 1; k <= kPrefetchAhead; ++k)
      for (int64_t e = 0; e < entries; ++e)
        for (const FrameInfo* frame :
             frames_for((iteration_ + k) * entries_per_step() + first_entry() + e))
          ahead.push_back(frame->index);
    frames_for(iteration_ * entries_per_step() + first_entry());  // restore this epoch's order
    capture_->prefetch(ahead);
  }
  const bool diagnostics = (iteration_ + 1) % config_.train.log_every == 0;
  EntryOutcome sums;  // loss and PSNR summed over this rank's entries, densification statistics
  std::vector<EntryOutcome> outcomes;
  bool finite = true;
  for (int64_t e = 0; e < entries; ++e) {
    outcomes.push_back(train_entry(e, diagnostics && e == 0, result));
    const auto& o = outcomes.back();
    finite = finite && std::isfinite(o.loss);
    sums.loss += o.loss;
    sums.psnr += o.psnr;
    views_rendered_ += o.views;
    if (o.densify.visible.defined()) {
      // Summed over the step's entries first, then added: the same sums on every rank layout.
      sums.densify.grad_norm = e == 0 ? o.densify.grad_norm : sums.densify.grad_norm + o.densify.grad_norm;
      sums.densify.visible = e == 0 ? o.densify.visible : sums.densify.visible + o.densify.visible;
    }
  }
  const auto t4 = Clock::now();
  std::vector<PoseUpdate> pose_updates;  // in entry order; data parallel: every rank's
  for (int64_t e = 0; e < entries; ++e) {
    const auto& o = outcomes[static_cast<size_t>(e)];
    if (o.pose_delta.defined() && o.pose_delta.grad().defined())
      pose_updates.push_back({first_entry() + e, o.pose_index, o.pose_delta.grad()});
  }

  if (group_) {
    finite = reduce_across_ranks(sums, finite, result.terms, pose_updates);
  } else {
    for (auto& group : optimizer_->groups())
      for (auto* p : group.params)
        if (finite && p->grad().defined() && !torch::isfinite(p->grad()).all().item<bool>())
          finite = false;
    for (const auto& update : pose_updates)  // data parallel: the all-reduce's check covers them
      if (finite && !torch::isfinite(update.grad).all().item<bool>()) finite = false;
  }
  result.loss = sums.loss / entries_per_step();
  result.psnr = sums.psnr / entries_per_step();
  auto& g = avatar_->gaussians();
  if (!finite) {
    optimizer_->zero_grad();
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
      if (group_) synchronize_state(/*keep_chains=*/false);
    }
  } else {
    bad_in_a_row_ = 0;
    optimizer_->step(iteration_, total);
    for (const auto& update : pose_updates) pose_corrections_->step(update.pose_index, update.grad);
    // The same values on every rank, so the same projection (rank 0 reports runaways).
    if (camera_colors_) camera_colors_->project(/*warn=*/is_root());
    if (sums.densify.visible.defined()) densifier_->add(sums.densify);
    optimizer_->zero_grad();
    if (config_.train.loss.consistency > 0) prev_chains_ = next_chains_;
    ++iteration_;
    if (densifier_->due(iteration_)) {
      const int64_t before = g.size();
      // Decided once, by rank 0, from statistics every rank holds; the others take its result.
      if (is_root())
        densifier_->densify_and_prune(g, *optimizer_,
                                      static_cast<uint64_t>(config_.train.seed) + iteration_);
      if (group_) synchronize_state(/*keep_chains=*/true);
      if (avatar_->gaussians().size() != before) {
        // Correspondences refer to rows: start the inter-pose state afresh.
        prev_chains_.assign(prev_chains_.size(), ConsistencyChain{});
        candidates_ = torch::Tensor();
        if (is_root())
          spdlog::debug("densify at step {}: {} -> {} Gaussians", iteration_, before,
                        avatar_->gaussians().size());
      }
    }
    running_psnr_ = running_psnr_ == 0 ? result.psnr : 0.95 * running_psnr_ + 0.05 * result.psnr;
  }
  result.iteration = iteration_;
  result.times.optimizer_ms = ms_between(t4, Clock::now());
  return result;
}

void Trainer::synchronize_state(bool keep_chains) {
  std::string bytes;
  if (group_->is_root()) bytes = checkpoint_bytes(make_checkpoint());
  group_->broadcast_bytes(bytes);
  if (group_->is_root()) return;
  const auto chains = prev_chains_;
  const std::string source = "rank 0's state";
  load_from(checkpoint_from_bytes(bytes, source), source);
  if (keep_chains)
    for (size_t i = 0; i < chains.size(); ++i)
      if (chains[i].descriptor.defined() &&
          chains[i].descriptor.size(0) == avatar_->gaussians().size())
        prev_chains_[i] = chains[i];
}

bool Trainer::rollback() {
  const auto files = list_checkpoints(run_dir_);
  require(!files.empty() || !initial_state_.empty(),
          "training diverged before the first checkpoint was written");
  require(rollbacks_ < kMaxRollbacks,
          "training diverged: " + std::to_string(rollbacks_) +
              " rollbacks did not help; lower train.lr.* or check the data");
  const double scale = optimizer_->lr_scale() * config_.train.rollback_lr_factor;
  const int64_t rollbacks = rollbacks_ + 1;
  const int64_t skipped = skipped_total_;
  const auto restore = [&](const Checkpoint& checkpoint, const std::string& source) {
    load_from(checkpoint, source);
    optimizer_->set_lr_scale(scale);
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

void Trainer::put_chains(Checkpoint& checkpoint) const {
  for (size_t i = 0; i < prev_chains_.size(); ++i) {
    const std::string prefix = chain_prefix(first_entry() + static_cast<int64_t>(i));
    const ConsistencyChain& chain = prev_chains_[i];
    for (const auto& [field, tensor] : {std::pair<const char*, const torch::Tensor&>{"descriptor", chain.descriptor},
                                        {"attributes", chain.attributes},
                                        {"pose_feature", chain.pose_feature},
                                        {"decoded", chain.decoded}})
      if (tensor.defined()) checkpoint.tensors[prefix + field] = tensor.clone();
  }
}

void Trainer::gather_chains() {
  // Each other rank's chains travel as a checkpoint of those tensors alone; rank 0 keeps them.
  Checkpoint mine;  // rank 0 sends nothing
  if (!is_root()) put_chains(mine);
  if (is_root()) other_chains_.clear();
  for (int rank = 1; rank < group_->world_size(); ++rank) {
    std::string bytes = group_->rank() == rank ? checkpoint_bytes(mine) : std::string();
    group_->broadcast_bytes(bytes, rank);
    if (!is_root()) continue;
    const std::string source = "rank " + std::to_string(rank) + "'s inter-pose chains";
    for (auto& [name, tensor] : checkpoint_from_bytes(bytes, source).tensors) other_chains_[name] = tensor;
  }
  other_chains_iteration_ = iteration_;
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
  ckpt.meta["adam_steps"] = optimizer_->steps();
  ckpt.meta["lr_scale"] = optimizer_->lr_scale();
  store_avatar(*avatar_, ckpt);
  for (auto& group : optimizer_->groups())
    for (size_t i = 0; i < group.params.size(); ++i) {
      const std::string base = "adam/" + group.name + "/" + std::to_string(i);
      ckpt.tensors[base + "/m"] = group.exp_avg[i].clone();
      ckpt.tensors[base + "/v"] = group.exp_avg_sq[i].clone();
    }
  auto put = [&](const std::string& name, const torch::Tensor& t) {
    if (t.defined()) ckpt.tensors[name] = t.clone();
  };
  put_chains(ckpt);
  if (other_chains_iteration_ == iteration_)
    for (const auto& [name, tensor] : other_chains_) ckpt.tensors.emplace(name, tensor);
  put("consistency/candidates", candidates_);
  if (pose_corrections_)
    for (const auto& [name, tensor] : pose_corrections_->state()) ckpt.tensors[name] = tensor;
  if (camera_colors_) camera_colors_->store(ckpt);
  put("densify/grad_sum", densifier_->grad_sum());
  put("densify/count", densifier_->visible_count());
  return ckpt;
}

void Trainer::load_from(const Checkpoint& ckpt, const std::string& source, bool allow_changed_data) {
  check_checkpoint_meta(ckpt.meta, source);
  RunConfig stored;
  config_from_json(ckpt.meta.at("config"), source + " (stored config)", stored);
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
  if (config_to_json(stored.model) != config_to_json(config_.model)) {
    std::string differences;
    for (const auto& line :
         json_differences(config_to_json(stored.model), config_to_json(config_.model), "model"))
      differences += "\n  " + line;
    throw Error(source + ": its model differs from the config given (checkpoint -> given):" +
                differences + "\nresume with the checkpoint's model settings");
  }
  avatar_ = std::make_unique<Avatar>(
      restore_avatar(ckpt, config_.model, load_rig_source(avatar_rig_source(config_)), source));
  camera_colors_ = make_camera_colors();
  // A checkpoint without transforms (older, or trained with camera_color off) starts them at the
  // identity, with fresh optimiser state.
  const bool colors_stored = camera_colors_ && camera_colors_->load(ckpt, source);
  if (camera_colors_ && !colors_stored)
    spdlog::info("{}: no colour transforms stored; train.camera_color starts at the identity", source);
  build_optimizer();
  for (auto& group : optimizer_->groups())
    for (size_t i = 0; i < group.params.size(); ++i) {
      const std::string base = "adam/" + group.name + "/" + std::to_string(i);
      auto m = ckpt.tensors.find(base + "/m");
      auto v = ckpt.tensors.find(base + "/v");
      if (group.name == kCameraColorGroup && !colors_stored) continue;
      if (m == ckpt.tensors.end() || v == ckpt.tensors.end())
        throw Error(source + ": checkpoint lacks optimiser state " + base);
      if (m->second.sizes() != group.params[i]->sizes())
        throw Error(source + ": optimiser state " + base + " does not match its parameter");
      group.exp_avg[i] = m->second.clone();
      group.exp_avg_sq[i] = v->second.clone();
    }
  optimizer_->set_steps(ckpt.meta.at("adam_steps").get<int64_t>());
  optimizer_->set_lr_scale(ckpt.meta.at("lr_scale").get<double>());
  iteration_ = ckpt.meta.at("iteration").get<int64_t>();
  skipped_total_ = ckpt.meta.value("skipped_steps", int64_t{0});
  rollbacks_ = ckpt.meta.value("rollbacks", int64_t{0});
  running_psnr_ = ckpt.meta.value("running_psnr", 0.0);
  elapsed_seconds_ = ckpt.meta.value("elapsed_seconds", 0.0);
  auto get = [&](const std::string& name) {
    auto it = ckpt.tensors.find(name);
    return it == ckpt.tensors.end() ? torch::Tensor() : it->second.clone();
  };
  for (size_t i = 0; i < prev_chains_.size(); ++i) {
    const std::string prefix = chain_prefix(first_entry() + static_cast<int64_t>(i));
    prev_chains_[i] = {get(prefix + "descriptor"), get(prefix + "attributes"),
                       get(prefix + "pose_feature"), get(prefix + "decoded")};
  }
  // Rank 0 keeps the other ranks' chains of the checkpoint: the broadcast that starts (or rolls
  // back) every rank then carries them.
  other_chains_.clear();
  other_chains_iteration_ = -1;
  if (group_ && group_->is_root()) {
    std::set<std::string> own;
    for (size_t i = 0; i < prev_chains_.size(); ++i) own.insert(chain_prefix(first_entry() + static_cast<int64_t>(i)));
    const std::string views = "consistency/view";
    for (const auto& [name, tensor] : ckpt.tensors) {
      if (name.rfind(views, 0) != 0) continue;
      if (!own.count(name.substr(0, name.find('/', views.size()) + 1))) other_chains_[name] = tensor.clone();
    }
    other_chains_iteration_ = iteration_;
  }
  candidates_ = get("consistency/candidates");
  if (pose_corrections_) {
    pose_corrections_ =
        std::make_unique<PoseCorrections>(capture_->num_poses(), config_.train.pose_refine);
    if (ckpt.tensors.count("pose_refine/values"))
      pose_corrections_->load_state(ckpt.tensors, source);
    else
      spdlog::info("{}: no pose corrections stored; pose refinement starts from the annotations",
                   source);
  }
  densifier_ = std::make_unique<Densifier>(config_.train.densify);
  if (auto grad_sum = get("densify/grad_sum"); grad_sum.defined()) {
    densifier_->grad_sum() = grad_sum;
    densifier_->visible_count() = get("densify/count");
  }
  bad_in_a_row_ = 0;
}

std::string Trainer::save_checkpoint() {
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
  const auto& frames = capture_->test().empty() ? capture_->train() : capture_->test();
  const FrameInfo& frame = frames.front();
  c10::InferenceMode guard;
  FrameSample sample = capture_->load(frame, /*full_image=*/true);
  auto out = avatar_->forward(float_vector(frame.pose), float_vector(frame.shape),
                              float_vector(frame.trans), sample.camera, RasterSettings{});
  const int64_t row = camera_colors_ ? camera_colors_->row(frame.camera_id) : -1;
  const auto rgb = row < 0 ? out.render.rgb
                           : apply_color_transform(out.render.rgb, out.render.alpha, {0, 0, 0},
                                                   camera_colors_->matrix(row));
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
  set("gaussians", avatar_->gaussians().size());
  set("skipped", skipped_total_);
  set("rollbacks", rollbacks_);
  set("lr_scale", optimizer_->lr_scale());
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

TrainSummary Trainer::run() {
  const StopSignal stop_signal;  // Ctrl-C, SIGTERM or SIGHUP: save a checkpoint and end
  stop_agreed_ = false;
  // Every rank starts from rank 0's state: its initialisation, or the checkpoint it resumed.
  if (group_) synchronize_state(/*keep_chains=*/false);
  const bool root = is_root();
  const bool consistency_chains = config_.train.loss.consistency > 0;  // what gather_chains moves
  const auto start = Clock::now();
  const double elapsed_before = elapsed_seconds_;
  const int64_t first_iteration = iteration_;
  const int64_t views_before = views_rendered_;
  const CommunicationStats communication_before = group_ ? group_->stats() : CommunicationStats{};
  // The state a rollback before the first checkpoint returns to, kept in memory: nothing is written
  // before the first logged step or checkpoint, so a run that stops at its first steps with a user
  // error (a crop too small for the image losses) leaves the folder as it was.
  if (root && last_checkpoint_.empty()) initial_state_ = checkpoint_bytes(make_checkpoint());
  const int64_t total = config_.train.iterations;
  std::unique_ptr<ProgressBar> bar;  // rank 0 reports for all
  if (root) bar = std::make_unique<ProgressBar>("train", total);
  char status[160] = "";
  int64_t chains_gathered_at = -1;  // the same on every rank, so all decide the final gather alike
  while (iteration_ < total && !stop_requested()) {
    const StepResult r = step();
    elapsed_seconds_ = elapsed_before + ms_between(start, Clock::now()) / 1000.0;
    const bool checkpoint_due = iteration_ % config_.train.checkpoint_every == 0;
    if (group_ && checkpoint_due && consistency_chains) {  // every rank takes part
      gather_chains();
      chains_gathered_at = iteration_;
    }
    if (!root) continue;
    std::snprintf(status, sizeof(status), "loss %.4f psnr %.2f (avg %.2f) N %lld%s", r.loss, r.psnr,
                  running_psnr_, static_cast<long long>(avatar_->gaussians().size()),
                  skipped_total_ ? (" skipped " + std::to_string(skipped_total_)).c_str() : "");
    bar->update(iteration_, status);
    if (iteration_ % config_.train.log_every == 0 || r.skipped) log_step(r);
    if (checkpoint_due) save_checkpoint();
    if (config_.train.validate_every > 0 && iteration_ % config_.train.validate_every == 0)
      validate();
  }
  const bool interrupted = stop_requested() && iteration_ < total;
  // For the final checkpoint (every rank gets here), unless the loop's last step just gathered.
  if (group_ && consistency_chains && chains_gathered_at != iteration_) gather_chains();
  if (root) {
    if (last_checkpoint_.find(checkpoint_name(iteration_)) == std::string::npos) save_checkpoint();
    if (pose_corrections_)
      write_file_atomic(run_dir_ + "/pose_refine.csv", pose_corrections_->to_csv());
    if (camera_colors_)
      write_file_atomic(run_dir_ + "/camera_color.csv", camera_colors_->to_csv());
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
  summary.gaussians = avatar_->gaussians().size();
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
