#include "train/trainer.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <csignal>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>

#include <opencv2/imgproc.hpp>
#include <spdlog/spdlog.h>
#include <torch/torch.h>

#include "core/atomic_file.h"
#include "core/config.h"
#include "core/error.h"
#include "core/float_vector.h"
#include "core/progress.h"
#include "data/camera_transforms.h"
#include "io/png.h"
#include "metrics/image_tensor.h"
#include "metrics/psnr.h"
#include "train/avatar_state_io.h"
#include "train/consistency.h"
#include "train/descriptor_tree.h"
#include "train/run_folder.h"

namespace handscs {

namespace {

std::atomic<bool> g_stop_requested{false};
extern "C" void request_stop(int) { g_stop_requested = true; }

using Clock = std::chrono::steady_clock;
double ms_between(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double, std::milli>(b - a).count();
}

constexpr int kCheckpointsKept = 2;  // the newest and the one before it (if the newest is damaged)
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



}  // namespace

Trainer::Trainer(const RunConfig& config, const std::string& run_dir)
    : config_(config), run_dir_(run_dir) {
  validate_run_config(config_, "config");
  ensure_directory(run_dir_);
  ensure_directory(run_dir_ + "/checkpoints");
  remove_stale_temporaries(run_dir_);

  capture_ = std::make_unique<Capture>(Capture::open(config_.data, run_dir_ + "/cache"));
  require(!capture_->train().empty(),
          "data: the capture has no training frames (check data.root, split, capture, cameras)");
  spdlog::info("capture: {} training and {} test frames, {} poses, {} cameras",
               capture_->train().size(), capture_->test().size(), capture_->num_poses(),
               capture_->cameras().size());

  avatar_ = std::make_unique<Avatar>(config_.model, load_rig_source(avatar_rig_source(config_)));
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

void Trainer::write_run_files() {
  // Not in the constructor: a resume that fails (or a config that fails later checks) must leave
  // the folder as it was.
  if (run_files_written_) return;
  write_file_atomic(run_dir_ + "/config.json", config_to_json(config_).dump(2) + "\n");
  const std::string metrics = run_dir_ + "/metrics.csv";
  if (!std::filesystem::exists(metrics)) {
    std::string header;
    for (size_t i = 0; i < std::size(kMetricsColumns); ++i)
      header += (i ? "," : "") + std::string(kMetricsColumns[i]);
    for (const char* column : kDiagnosticColumns) header += "," + std::string(column);
    write_file_atomic(metrics, header + "\n");
  }
  run_files_written_ = true;
}

Trainer::~Trainer() = default;

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
}

const FrameInfo& Trainer::frame_for(int64_t iteration) {
  const auto& frames = capture_->train();
  const int64_t n = static_cast<int64_t>(frames.size());
  const int64_t epoch = iteration / n;
  if (epoch != order_epoch_) {
    order_.resize(n);
    for (int64_t i = 0; i < n; ++i) order_[i] = i;
    // The order is a function of (seed, epoch) alone, so a resumed run sees the same frames.
    std::mt19937_64 rng(static_cast<uint64_t>(config_.train.seed) * 1000003ull + epoch);
    std::shuffle(order_.begin(), order_.end(), rng);
    order_epoch_ = epoch;
  }
  return frames[order_[iteration % n]];
}

std::array<float, 3> Trainer::background_for(int64_t iteration) const {
  if (config_.train.background == TrainConfig::Background::white) return {1, 1, 1};
  if (config_.train.background == TrainConfig::Background::black) return {0, 0, 0};
  std::mt19937_64 rng(static_cast<uint64_t>(config_.train.seed) * 7919ull + iteration);
  std::uniform_real_distribution<float> u(0.f, 1.f);
  return {u(rng), u(rng), u(rng)};
}

torch::Tensor Trainer::consistency_loss(const AvatarState& state, const torch::Tensor& rendered_pose,
                                        double* pair_weight) {
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
  const double weight = prev_descriptor_.defined()
                            ? pose_similarity(feature, prev_pose_feature_, cc.delta)
                            : 0.0;
  if (prev_descriptor_.defined()) *pair_weight = weight;
  if (prev_descriptor_.defined() && prev_descriptor_.size(0) == g.size() &&
      weight >= cc.min_weight) {
    torch::Tensor match;
    const bool gemm =
        cc.search == ConsistencyConfig::Search::exact ||
        (cc.search == ConsistencyConfig::Search::automatic && g.size() <= cc.exact_max_gaussians);
    if (gemm) {
      match = correspond_exact(state.descriptor, prev_descriptor_);
    } else if (cc.search == ConsistencyConfig::Search::candidates) {
      if (!candidates_.defined() || candidates_.size(0) != g.size() ||
          iteration_ % cc.refresh_every == 0)
        candidates_ = nearest_neighbours(g.means, cc.candidates);
      match = correspond_candidates(state.descriptor, prev_descriptor_, candidates_);
    } else {
      // Rows persist between steps (the state is reset on densification): each Gaussian's own
      // previous row is the natural first guess.
      match = DescriptorTree(prev_descriptor_).nearest(state.descriptor,
                                                       torch::arange(g.size(), torch::kInt64));
    }
    const auto diff = consistency_distances(attributes, prev_attributes_.index_select(0, match),
                                            state.canonical_covariances, cc.normalize);
    loss = weight * (cc.reduction == ConsistencyConfig::Reduction::sum ? diff.sum() : diff.mean());
  }
  // Kept for the next step (M_0 = M_1 on the first step: no loss).
  next_descriptor_ = state.descriptor.detach();
  next_attributes_ = attributes.detach();
  next_pose_feature_ = feature;
  return loss;
}

StepResult Trainer::step() {
  StepResult result;
  const auto t0 = Clock::now();
  const int64_t total = config_.train.iterations;
  {
    std::vector<int64_t> ahead;
    for (int k = 1; k <= kPrefetchAhead; ++k) ahead.push_back(frame_for(iteration_ + k).index);
    frame_for(iteration_);  // restore this epoch's order if the look-ahead crossed an epoch
    capture_->prefetch(ahead);
  }
  const FrameInfo& current = frame_for(iteration_);
  FrameSample sample = capture_->load(current);
  empty_masks_->record(current, !sample.mask.any().item<bool>());
  Camera camera = sample.roi_camera();
  torch::Tensor image = sample.image.to(torch::kFloat32).div_(255.0);  // [h, w, 3]
  torch::Tensor mask = sample.mask.to(torch::kFloat32);                // [h, w]
  const double scale = config_.train.resolution_scale;
  if (scale != 1.0) {
    const int w = std::max(1, static_cast<int>(std::lround(camera.width * scale)));
    const int h = std::max(1, static_cast<int>(std::lround(camera.height * scale)));
    cv::Mat img(image.size(0), image.size(1), CV_32FC3, image.data_ptr<float>());
    cv::Mat msk(mask.size(0), mask.size(1), CV_32FC1, mask.data_ptr<float>());
    cv::Mat img_small, msk_small;
    cv::resize(img, img_small, cv::Size(w, h), 0, 0, cv::INTER_AREA);
    cv::resize(msk, msk_small, cv::Size(w, h), 0, 0, cv::INTER_AREA);
    image = torch::from_blob(img_small.data, {h, w, 3}, torch::kFloat32).clone();
    mask = torch::from_blob(msk_small.data, {h, w}, torch::kFloat32).clone();
    camera = resample_camera(camera, double(w) / camera.width, w, h);
  }
  const std::string too_small = scaled_crop_problem(current, static_cast<int>(image.size(1)),
                                                    static_cast<int>(image.size(0)), scale,
                                                    min_loss_side_);
  if (!too_small.empty()) throw Error(too_small);
  const auto bg = background_for(iteration_);
  const auto bg_tensor = torch::tensor({bg[0], bg[1], bg[2]});
  const auto target = image * mask.unsqueeze(2) + bg_tensor * (1 - mask.unsqueeze(2));
  const auto t1 = Clock::now();

  auto& g = avatar_->gaussians();
  const bool densify = config_.train.densify.enabled;
  const auto probe = densify ? torch::zeros({g.size(), 2}).requires_grad_(true) : torch::Tensor();
  const bool consistency = config_.train.loss.consistency > 0;
  RasterSettings settings;
  settings.background = bg;
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
  auto out = avatar_->forward(pose, float_vector(current.shape), trans, camera, settings, probe,
                              consistency);
  const auto t2 = Clock::now();

  LossInputs in;
  in.rgb = out.render.rgb;
  in.alpha = out.render.alpha;
  in.target = target;
  in.mask = mask;
  in.offsets = &out.state.offsets;
  if (consistency) in.consistency = consistency_loss(out.state, pose, &result.consistency_weight);
  auto loss = objective_->compute(in);
  if (learn_pose) {
    const auto penalty = pose_corrections_->penalty(corrected.delta);
    loss.terms["pose_refine"] = penalty.item<double>();
    loss.total = loss.total + penalty;
  }
  if ((iteration_ + 1) % config_.train.log_every == 0) {
    // Whether the decoders do anything: their gates and the mean size of each offset, on the
    // steps run() logs (each is a reduction and a sync; no need on every step).
    torch::NoGradGuard no_grad;
    const auto& decoders = avatar_->decoders();
    result.diagnostics["gate_geometry"] = decoders->geometry->gate.item<double>();
    result.diagnostics["gate_appearance"] = decoders->appearance->gate.item<double>();
    result.diagnostics["gate_fusion"] = decoders->fusion->gate.item<double>();
    for (const auto& [name, norms] : offset_norms(out.state.offsets))
      result.diagnostics["offset_" + name] = norms.mean().item<double>();
    if (pose_corrections_)
      for (const auto& [name, value] : pose_corrections_->summary()) result.diagnostics[name] = value;
  }
  const auto t3 = Clock::now();

  loss.total.backward();
  const auto t4 = Clock::now();

  bool finite = std::isfinite(loss.total.item<double>());
  for (auto& group : optimizer_->groups())
    for (auto* p : group.params)
      if (finite && p->grad().defined() && !torch::isfinite(p->grad()).all().item<bool>())
        finite = false;
  if (finite && learn_pose && corrected.delta.grad().defined() &&
      !torch::isfinite(corrected.delta.grad()).all().item<bool>())
    finite = false;
  result.loss = loss.total.item<double>();
  result.terms = loss.terms;
  {
    torch::NoGradGuard no_grad;
    const double mse = (out.render.rgb.detach() - target).pow(2).mean().item<double>();
    // Capped: a crop rendered exactly (mse 0, +inf dB) would make the running average infinite.
    constexpr double kMaxStepPsnr = 99.0;
    result.psnr = std::min(psnr_from_mse(mse), kMaxStepPsnr);
  }
  if (!finite) {
    optimizer_->zero_grad();
    ++skipped_total_;
    ++bad_in_a_row_;
    result.skipped = true;
    spdlog::warn("step {}: non-finite loss or gradient, step skipped ({} in a row)", iteration_ + 1,
                 bad_in_a_row_);
    ++iteration_;
    if (bad_in_a_row_ >= config_.train.max_bad_steps) result.rolled_back = rollback();
  } else {
    bad_in_a_row_ = 0;
    optimizer_->step(iteration_, total);
    if (learn_pose && corrected.delta.grad().defined())
      pose_corrections_->step(current.pose_index, corrected.delta.grad());
    if (densify && probe.grad().defined())
      densifier_->accumulate(probe.grad(), out.render.radii);
    optimizer_->zero_grad();
    if (consistency) {
      prev_descriptor_ = next_descriptor_;
      prev_attributes_ = next_attributes_;
      prev_pose_feature_ = next_pose_feature_;
    }
    ++iteration_;
    if (densifier_->due(iteration_)) {
      const int64_t before = g.size();
      densifier_->densify_and_prune(g, *optimizer_,
                                    static_cast<uint64_t>(config_.train.seed) + iteration_);
      if (g.size() != before) {
        // Correspondences refer to rows: start the inter-pose state afresh.
        prev_descriptor_ = prev_attributes_ = candidates_ = torch::Tensor();
        spdlog::debug("densify at step {}: {} -> {} Gaussians", iteration_, before, g.size());
      }
    }
    running_psnr_ = running_psnr_ == 0 ? result.psnr : 0.95 * running_psnr_ + 0.05 * result.psnr;
  }
  const auto t5 = Clock::now();
  result.iteration = iteration_;
  result.times = {ms_between(t0, t1), ms_between(t1, t2), ms_between(t2, t3), ms_between(t3, t4),
                  ms_between(t4, t5)};
  return result;
}

bool Trainer::rollback() {
  const auto files = list_checkpoints(run_dir_);
  require(!files.empty(), "training diverged before the first checkpoint was written");
  require(rollbacks_ < kMaxRollbacks,
          "training diverged: " + std::to_string(rollbacks_) +
              " rollbacks did not help; lower train.lr.* or check the data");
  const double scale = optimizer_->lr_scale() * config_.train.rollback_lr_factor;
  const int64_t rollbacks = rollbacks_ + 1;
  const int64_t skipped = skipped_total_;
  for (const auto& file : files) {
    try {
      load_from(load_checkpoint(file), file);
      optimizer_->set_lr_scale(scale);
      rollbacks_ = rollbacks;
      skipped_total_ = skipped;
      bad_in_a_row_ = 0;
      spdlog::warn("rolled back to {} (step {}), learning rates x{:.3g}", file, iteration_, scale);
      return true;
    } catch (const Error& e) {
      spdlog::warn("{}", e.what());
    }
  }
  throw Error("training diverged and no checkpoint in " + run_dir_ + "/checkpoints could be loaded");
}

Checkpoint Trainer::make_checkpoint() {
  Checkpoint ckpt;
  ckpt.meta["format"] = "handscs-checkpoint";
  ckpt.meta["version"] = 1;
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
  put("consistency/descriptor", prev_descriptor_);
  put("consistency/attributes", prev_attributes_);
  put("consistency/pose_feature", prev_pose_feature_);
  put("consistency/candidates", candidates_);
  if (pose_corrections_)
    for (const auto& [name, tensor] : pose_corrections_->state()) ckpt.tensors[name] = tensor;
  put("densify/grad_sum", densifier_->grad_sum());
  put("densify/count", densifier_->visible_count());
  return ckpt;
}

void Trainer::load_from(const Checkpoint& ckpt, const std::string& source) {
  if (ckpt.meta.value("format", "") != "handscs-checkpoint")
    throw Error(source + ": not a HandSCS training checkpoint");
  RunConfig stored;
  config_from_json(ckpt.meta.at("config"), source + " (stored config)", stored);
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
  build_optimizer();
  for (auto& group : optimizer_->groups())
    for (size_t i = 0; i < group.params.size(); ++i) {
      const std::string base = "adam/" + group.name + "/" + std::to_string(i);
      auto m = ckpt.tensors.find(base + "/m");
      auto v = ckpt.tensors.find(base + "/v");
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
  prev_descriptor_ = get("consistency/descriptor");
  prev_attributes_ = get("consistency/attributes");
  prev_pose_feature_ = get("consistency/pose_feature");
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
  const std::string path = run_dir_ + "/checkpoints/" + checkpoint_name(iteration_);
  handscs::save_checkpoint(path, make_checkpoint());
  last_checkpoint_ = path;
  const auto files = list_checkpoints(run_dir_);
  for (size_t i = kCheckpointsKept; i < files.size(); ++i) std::filesystem::remove(files[i]);
  return path;
}

bool Trainer::resume() {
  const auto files = list_checkpoints(run_dir_);
  std::string reasons;
  for (const auto& file : files) {
    try {
      load_from(load_checkpoint(file), file);
      last_checkpoint_ = file;
      spdlog::info("resumed from {} at step {}", file, iteration_);
      truncate_metrics_log(run_dir_ + "/metrics.csv", iteration_);
      return true;
    } catch (const Error& e) {
      spdlog::warn("cannot resume from {}; trying an older checkpoint", e.what());
      reasons += "\n" + std::string(e.what());
    }
  }
  if (!files.empty())
    throw Error(run_dir_ + ": none of its " + std::to_string(files.size()) +
                " checkpoints can be resumed; nothing was changed:" + reasons);
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
  const auto mask = sample.mask.to(torch::kFloat32).unsqueeze(2);
  const auto gt = sample.image.to(torch::kFloat32).div(255.0) * mask;
  const auto side_by_side = torch::cat({out.render.rgb.clamp(0, 1), gt}, 1);
  ensure_directory(run_dir_ + "/validation");
  char name[64];
  std::snprintf(name, sizeof(name), "/validation/step_%08lld.png", static_cast<long long>(iteration_));
  write_png(run_dir_ + name, rgb_tensor_to_mat(side_by_side));
}

void Trainer::log_step(const StepResult& r) {
  write_run_files();
  static const char* terms[] = {"rgb", "mask", "ssim", "lpips", "reg", "consistency"};
  std::ofstream out(run_dir_ + "/metrics.csv", std::ios::app);
  out << r.iteration << "," << elapsed_seconds_ << "," << r.loss;
  for (const char* t : terms) {
    auto it = r.terms.find(t);
    out << ",";
    if (it != r.terms.end()) out << it->second;
  }
  out << "," << r.psnr << "," << avatar_->gaussians().size() << "," << skipped_total_ << ","
      << rollbacks_ << "," << optimizer_->lr_scale() << "," << r.times.data_ms << ","
      << r.times.forward_ms << "," << r.times.losses_ms << "," << r.times.backward_ms << ","
      << r.times.optimizer_ms;
  for (const char* column : kDiagnosticColumns) {
    auto it = r.diagnostics.find(column);
    out << ",";
    if (it != r.diagnostics.end()) out << it->second;
  }
  out << "\n";
}

TrainSummary Trainer::run() {
  g_stop_requested = false;
  auto previous_int = std::signal(SIGINT, request_stop);
  auto previous_term = std::signal(SIGTERM, request_stop);
  write_run_files();
  const auto start = Clock::now();
  const double elapsed_before = elapsed_seconds_;
  if (last_checkpoint_.empty()) save_checkpoint();  // the state a first rollback returns to
  const int64_t total = config_.train.iterations;
  ProgressBar bar("train", total);
  char status[160] = "";
  while (iteration_ < total && !g_stop_requested) {
    const StepResult r = step();
    elapsed_seconds_ = elapsed_before + ms_between(start, Clock::now()) / 1000.0;
    std::snprintf(status, sizeof(status), "loss %.4f psnr %.2f (avg %.2f) N %lld%s", r.loss, r.psnr,
                  running_psnr_, static_cast<long long>(avatar_->gaussians().size()),
                  skipped_total_ ? (" skipped " + std::to_string(skipped_total_)).c_str() : "");
    bar.update(iteration_, status);
    if (iteration_ % config_.train.log_every == 0 || r.skipped) log_step(r);
    if (iteration_ % config_.train.checkpoint_every == 0) save_checkpoint();
    if (config_.train.validate_every > 0 && iteration_ % config_.train.validate_every == 0)
      validate();
  }
  const bool interrupted = g_stop_requested && iteration_ < total;
  if (last_checkpoint_.find(checkpoint_name(iteration_)) == std::string::npos) save_checkpoint();
  if (pose_corrections_)
    write_file_atomic(run_dir_ + "/pose_refine.csv", pose_corrections_->to_csv());
  bar.finish(status);
  std::signal(SIGINT, previous_int);
  std::signal(SIGTERM, previous_term);
  if (interrupted)
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
  return summary;
}

}  // namespace handscs
