// handscs-bench-model's train_step_ms: one full training step (Trainer::step: ROI crop, avatar
// forward with the densification probe and L_con, every loss, backward, Adam) at N Gaussians, on
// a small synthetic capture generated once per benchmark run (the `bench` preset's 334x512 /
// 512x334 cameras, 4 cameras x 30 poses). The avatar reaches N the way a densifying run does:
// densification every step from step 1 with a threshold that takes any visible Gaussian, capped at
// N, stopped before the timed steps.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "run/run_config.h"
#include "synth/capture.h"
#include "synth/config.h"
#include "train/trainer.h"
#include "bench_timing.h"
#include "../train/two_hand_capture.h"

namespace bench {

struct TrainStepOptions {
  std::string capture_dir;    // from make_train_step_capture
  std::string lpips_weights;  // empty: the LPIPS term is skipped (reported in the JSON)
  int decoder_hidden = 256;
  std::string decoder_precision = "auto";
  int repeats = 10;
  int64_t lpips_every = handscs::LossWeights{}.lpips_every;  // train.loss.lpips_every
  double lpips_scale = handscs::LossWeights{}.lpips_scale;   // train.loss.lpips_scale
  int64_t views_per_pose = 1;  // train.views_per_pose: cameras of one pose per step, one decoding
  bool cull = false;           // train.cull.enabled: back-facing Gaussians skipped
  double cull_max_cos = handscs::CullConfig{}.max_cos;  // train.cull.max_cos
  // data.hand: both needs a capture from make_train_step_capture(dir, true); N is then per hand.
  handscs::CaptureConfig::Hands hand = handscs::CaptureConfig::Hands::right;
};

// Writes the capture into dir (replacing what is there) and returns dir. two_hands: in the
// project's layout, each frame with a left hand beside the right (train/two_hand_capture.h).
inline std::string make_train_step_capture(const std::string& dir, bool two_hands = false) {
  std::filesystem::remove_all(dir);
  auto config = handscs::synth_preset("bench");
  config.num_cameras = 4;  // four cameras x 30 poses: 120 images, ~3 s to generate
  config.num_frames = 30;
  config.held_out_frames = 5;
  if (two_hands) config.layout = handscs::CaptureConfig::Layout::handscs;
  handscs::generate_synth_capture(config, dir);
  if (two_hands) handscs_test::add_left_hands(dir);
  return dir;
}

// Steps taken to grow the avatar before timing: densification doubles the count at most, so 12
// reach 20k from the built-in hand's 1,696 with room to spare.
constexpr int kGrowSteps = 12;

// The median step (and the mean: with lpips_every > 1 steps alternate between two costs) and the
// median stages over opt.repeats steps (after kGrowSteps + 2 warm-up steps), or
// null when N is below the built-in hand's Gaussian count (densification only grows).
inline nlohmann::json time_train_steps(int64_t n, const TrainStepOptions& opt) {
  handscs::RunConfig config;
  config.data.root = opt.capture_dir;
  config.data.held_out_poses = 5;
  config.data.hand = opt.hand;
  config.data.include_interacting = true;  // a two-hand capture's frames show both hands
  config.model.decoder_hidden = opt.decoder_hidden;
  {
    auto json = handscs::config_to_json(config.model);
    json["decoder_precision"] = opt.decoder_precision;
    handscs::config_from_json(json, "--decoder-precision", config.model);
  }
  config.eval.lpips.weights = opt.lpips_weights;
  config.train.loss.lpips_every = opt.lpips_every;
  config.train.loss.lpips_scale = opt.lpips_scale;
  config.train.views_per_pose = opt.views_per_pose;
  config.train.cull.enabled = opt.cull;
  config.train.cull.max_cos = opt.cull_max_cos;
  config.train.iterations = kGrowSteps + 2 + opt.repeats;
  config.train.validate_every = 0;
  auto& d = config.train.densify;
  d.enabled = true;
  d.start = 1;
  d.interval = 1;
  d.stop = kGrowSteps;
  d.grad_threshold = 1e-12;  // any Gaussian that received a gradient
  d.min_opacity = 0;         // grow only
  d.max_gaussians = n;
  const auto run_dir = opt.capture_dir + "_run";
  std::filesystem::remove_all(run_dir);
  handscs::Trainer trainer(config, run_dir);
  const int64_t hands = trainer.hand_count();
  if (trainer.avatar().gaussians().size() > n) return nullptr;
  std::vector<double> step, data, forward, losses, backward, optimizer;
  size_t views = 0;
  for (int s = 0; s < config.train.iterations; ++s) {
    const auto t0 = Clock::now();
    const auto r = trainer.step();
    const double ms = ms_since(t0);
    if (s < kGrowSteps + 2) continue;
    step.push_back(ms);
    views += r.frames.size();
    data.push_back(r.times.data_ms);
    forward.push_back(r.times.forward_ms);
    losses.push_back(r.times.losses_ms);
    backward.push_back(r.times.backward_ms);
    optimizer.push_back(r.times.optimizer_ms);
  }
  std::filesystem::remove_all(run_dir);
  const int64_t reached = trainer.gaussian_count();
  if (reached != n * hands)
    spdlog::warn("train step: the avatar grew to {} Gaussians, not {}", reached, n * hands);
  double total = 0;
  for (double ms : step) total += ms;
  return {{"gaussians", reached},
          {"step_ms", median(step)},
          {"mean_step_ms", step.empty() ? 0.0 : total / step.size()},
          // Views rendered per step (train.views_per_pose, fewer if a pose has fewer cameras).
          {"views_per_step", step.empty() ? 0.0 : double(views) / step.size()},
          {"stages_ms",
           {{"data", median(data)},
            {"forward", median(forward)},
            {"losses", median(losses)},
            {"backward", median(backward)},
            {"optimizer", median(optimizer)}}}};
}

}  // namespace bench
