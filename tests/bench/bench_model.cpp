// handscs-bench-model: forward and backward ms of the full avatar step (no losses) for several
// Gaussian counts, split by stage (LBS, SCS = descriptor + virtual-bone generator, decoders,
// rasterizer), render_fps: the inference path handscs-render takes for a new pose, and
// train_step_ms: one full training step with every loss (train_step_timing.h). Prints one JSON
// object. Usage:
//   handscs-bench-model [--gaussians 778,5000,10000,20000] [--width 512] [--height 334]
//                       [--threads 2] [--repeats 10] [--decoder-hidden 256]
//                       [--decoder-precision auto|float|bf16] [--lpips-weights FILE]
//                       [--lpips-every 1] [--views-per-pose 1] [--no-train-step]
//                       [--work-dir /tmp/handscs-bench-model] [--profile-ops TRACE]
// --profile-ops writes LibTorch's op trace of `repeats` further forward + backward steps per count
// to TRACE_<count>.json and of `repeats` further novel-pose renders to TRACE_<count>_render.json
// (Chrome trace format; tools/study/profile_ops.py totals self time per op).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <sstream>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <torch/csrc/autograd/profiler_legacy.h>
#include <torch/types.h>

#include "avatar/avatar.h"
#include "avatar/covariance_chain.h"
#include "avatar/frozen_decoders.h"
#include "core/allocator.h"
#include "core/config.h"
#include "core/logging.h"
#include "core/threads.h"
#include "hand/lbs.h"
#include "hand/lbs_one_pose.h"
#include "scs/descriptor.h"
#include "bench_timing.h"
#include "grown_avatar.h"
#include "train_step_timing.h"

namespace {

using bench::Clock;
using bench::median;
using bench::ms_since;
using bench::seconds_since;

}  // namespace

int main(int argc, char** argv) {
  handscs::log_to_stderr();  // stdout carries the JSON only
  handscs::keep_freed_memory_for_reuse();  // as the tools run (core/allocator.h)
  CLI::App app{"Avatar forward/backward benchmark (prints JSON)"};
  std::string counts = "778,5000,10000,20000";
  int width = 512, height = 334, threads = 2, repeats = 10;
  app.add_option("--gaussians", counts, "comma-separated Gaussian counts");
  app.add_option("--width", width);
  app.add_option("--height", height);
  app.add_option("--threads", threads);
  app.add_option("--repeats", repeats);
  int decoder_hidden = 256;
  std::string precision = "auto";
  app.add_option("--decoder-hidden", decoder_hidden, "model.decoder_hidden (paper: 256)");
  app.add_option("--decoder-precision", precision, "model.decoder_precision: auto, float, bf16");
  bench::TrainStepOptions train_step;
  bool no_train_step = false;
  std::string work_dir = "/tmp/handscs-bench-model";
  app.add_option("--lpips-weights", train_step.lpips_weights,
                 "LPIPS weight file for the training step's LPIPS term (without: the term is skipped)");
  app.add_option("--lpips-every", train_step.lpips_every,
                 "train.loss.lpips_every of the training step (see mean_step_ms then)");
  app.add_option("--lpips-scale", train_step.lpips_scale,
                 "train.loss.lpips_scale of the training step (LPIPS on the crop scaled by this)")
      ->check(CLI::Range(0.05, 1.0));
  app.add_option("--views-per-pose", train_step.views_per_pose,
                 "train.views_per_pose of the training step (cameras of one pose sharing a decoding)")
      ->check(CLI::Range(1, 4));
  app.add_flag("--cull", train_step.cull, "train.cull.enabled in the training step (back-facing Gaussians skipped)");
  app.add_option("--cull-max-cos", train_step.cull_max_cos,
                 "train.cull.max_cos of the culled timings and of the --cull training step")
      ->check(CLI::Range(-1.0, 1.0));
  app.add_flag("--no-train-step", no_train_step, "skip train_step_ms (saves generating a capture)");
  app.add_option("--work-dir", work_dir, "where the training step's synthetic capture is written")
      ->capture_default_str();
  std::string profile_ops;
  app.add_option("--profile-ops", profile_ops,
                 "after the timed runs, write LibTorch's op trace of `repeats` more forward + backward "
                 "steps per count to TRACE_<count>.json and of as many renders to "
                 "TRACE_<count>_render.json (tools/study/profile_ops.py sums them)");
  CLI11_PARSE(app, argc, argv);
  handscs::set_threads(threads);
  train_step.decoder_hidden = decoder_hidden;
  train_step.decoder_precision = precision;
  train_step.repeats = repeats;
  if (!no_train_step) train_step.capture_dir = bench::make_train_step_capture(work_dir + "/capture");
  torch::manual_seed(0);

  nlohmann::json result;
  result["width"] = width;
  result["height"] = height;
  result["threads"] = threads;
  result["repeats"] = repeats;
  result["decoder_hidden"] = decoder_hidden;
  result["decoder_precision"] = precision;
  result["blas"] = handscs::blas_in_use();
  result["train_step_lpips"] = !no_train_step && !train_step.lpips_weights.empty();
  result["train_step_lpips_every"] = train_step.lpips_every;
  result["train_step_lpips_scale"] = train_step.lpips_scale;
  result["train_step_views_per_pose"] = train_step.views_per_pose;
  result["train_step_cull"] = train_step.cull;
  result["cull_max_cos"] = train_step.cull_max_cos;
  const auto camera = bench::capture_camera(width, height);
  const auto pose = torch::randn({48}) * 0.2;
  const auto shape = torch::zeros({10});
  const auto trans = torch::zeros({3});

  std::stringstream list(counts);
  std::string item;
  while (std::getline(list, item, ',')) {
    const int64_t n = std::stoll(item);
    handscs::AvatarConfig config;
    config.decoder_hidden = decoder_hidden;
    {
      // The name as a config file gives it (auto, float, bf16), checked by the config reader.
      auto json = handscs::config_to_json(config);
      json["decoder_precision"] = precision;
      handscs::config_from_json(json, "--decoder-precision", config);
    }
    handscs::Avatar avatar(config, handscs::load_rig_source("builtin"));
    bench::grow(avatar, n);
    bench::open_gates(avatar);
    // One forward + backward of the full step (no losses), timed as a whole; gradients cleared.
    // With cull: what training does with train.cull (the Gaussians facing away from the camera are
    // neither decoded nor rasterised).
    handscs::FacingCull facing;
    facing.camera_centres = {camera.centre()};
    facing.max_cos = train_step.cull_max_cos;
    double decoded_fraction = 1.0;  // of the culled forward + backward
    const auto forward_backward = [&](double& fwd, double& bwd, const handscs::FacingCull* cull) {
      auto t0 = Clock::now();
      const auto state = avatar.pose(pose, shape, trans, false, cull);
      const auto render = handscs::render_posed(state.posed, camera, {});
      fwd = ms_since(t0);
      if (cull) decoded_fraction = state.decoded_fraction();
      const auto cotangent = torch::rand_like(render.rgb);
      t0 = Clock::now();
      ((render.rgb * cotangent).sum() + render.alpha.sum()).backward();
      bwd = ms_since(t0);
      for (auto& [name, tensor] : avatar.gaussians().learnable())
        if (tensor->grad().defined()) tensor->mutable_grad().reset();
      avatar.decoders()->zero_grad();
      if (avatar.generator()) avatar.generator()->zero_grad();
      return cotangent;
    };
    std::vector<double> t_lbs, t_scs, t_dec, t_raster_fwd, t_forward, t_backward, t_raster_bwd,
        t_culled;
    for (int r = 0; r < repeats + 2; ++r) {  // two warm-up runs
      double fwd = 0.0, bwd = 0.0, culled_fwd = 0.0, culled_bwd = 0.0;
      (void)forward_backward(culled_fwd, culled_bwd, &facing);
      const auto cotangent = forward_backward(fwd, bwd, nullptr);

      // Stages, each timed on its own with the same inputs.
      auto t0 = Clock::now();
      const auto l = handscs::lbs(avatar.rig(), pose.view({1, 48}), shape.view({1, 10}),
                                  trans.view({1, 3}));
      const double lbs_ms = ms_since(t0);
      auto state = avatar.pose(pose, shape, trans);  // everything but the rasterizer
      const auto& p = state.posed;
      const auto means = p.means.detach().requires_grad_(true);
      const auto covs = p.covariances.detach().requires_grad_(true);
      const auto colors = p.colors.detach().requires_grad_(true);
      const auto opac = p.opacities.detach().requires_grad_(true);
      t0 = Clock::now();
      auto raster = handscs::rasterize_gaussians(means, covs, colors, opac, camera, {});
      const double raster_ms = ms_since(t0);
      t0 = Clock::now();
      ((raster.rgb * cotangent).sum() + raster.alpha.sum()).backward();
      const double raster_bwd_ms = ms_since(t0);
      // Descriptor + generator, then decoders alone.
      t0 = Clock::now();
      handscs::VirtualBones bones;
      const auto descriptor =
          avatar.compute_descriptor(pose, state.lbs, state.lbs_means.detach(), &bones);
      const double scs_ms = ms_since(t0);
      const auto transforms = torch::randn({n, 12});
      t0 = Clock::now();
      (void)avatar.decoders()->outputs(descriptor.detach(), avatar.gaussians().embed_geometry,
                                       avatar.gaussians().embed_appearance, transforms);
      const double dec_ms = ms_since(t0);
      if (r < 2) continue;
      t_forward.push_back(fwd);
      t_backward.push_back(bwd);
      t_culled.push_back(culled_fwd + culled_bwd);
      t_lbs.push_back(lbs_ms);
      t_scs.push_back(scs_ms);
      t_dec.push_back(dec_ms);
      t_raster_fwd.push_back(raster_ms);
      t_raster_bwd.push_back(raster_bwd_ms);
    }
    if (!profile_ops.empty()) {
      torch::autograd::profiler::RecordProfile record(profile_ops + "_" + std::to_string(n) + ".json");
      double fwd = 0.0, bwd = 0.0;
      for (int r = 0; r < repeats; ++r) (void)forward_backward(fwd, bwd, nullptr);
    }
    // What handscs-render does for a new pose: the whole forward under inference mode (no autograd
    // graph), a new random pose every frame so nothing pose-dependent can be reused.
    // Alternated with the same under a FacingCull of the camera (measured only: handscs-render
    // does not offer the cull, docs/BENCHMARKS.md#model-forward-and-backward).
    std::vector<double> t_render, t_render_culled, t_render_pose, t_render_raster;
    {
      c10::InferenceMode guard;
      const auto render_novel_pose = [&](const handscs::FacingCull* cull) {
        const auto novel_pose = torch::randn({48}) * 0.2;
        const auto t0 = Clock::now();
        (void)handscs::render_posed(avatar.pose(novel_pose, shape, trans, false, cull).posed, camera, {});
        return ms_since(t0);
      };
      for (int r = 0; r < repeats + 2; ++r) {
        const double ms = render_novel_pose(nullptr);
        const double culled_ms = render_novel_pose(&facing);
        if (r < 2) continue;
        t_render.push_back(ms);
        t_render_culled.push_back(culled_ms);
      }
      // The same frame in its two parts, wall-clock: posing (skinning, descriptor, decoders, 3x3
      // chain) and the rasterizer.
      for (int r = 0; r < repeats + 2; ++r) {
        const auto novel_pose = torch::randn({48}) * 0.2;
        handscs::AvatarState state;
        const double pose_ms = bench::ms_of([&] { state = avatar.pose(novel_pose, shape, trans); });
        const double raster_ms = bench::ms_of([&] { (void)handscs::render_posed(state.posed, camera, {}); });
        if (r < 2) continue;
        t_render_pose.push_back(pose_ms);
        t_render_raster.push_back(raster_ms);
      }
      if (!profile_ops.empty()) {
        torch::autograd::profiler::RecordProfile record(profile_ops + "_" + std::to_string(n) + "_render.json");
        for (int r = 0; r < repeats; ++r) (void)render_novel_pose(nullptr);
      }
    }
    // The decoders alone at inference, alternating in one process (so that the machine's slow and
    // fast phases hit both alike): OffsetDecoders::forward against the frozen form.
    std::vector<double> t_decoders_plain, t_decoders_frozen;
    {
      c10::InferenceMode guard;
      const auto state = avatar.pose(pose, shape, trans);
      const auto descriptor = state.descriptor.defined() ? state.descriptor : torch::zeros({n, 0});
      const auto transforms = torch::randn({n, 12});
      const auto& g = avatar.gaussians();
      const handscs::FrozenDecoders frozen(*avatar.decoders(), g.embed_geometry, g.embed_appearance);
      for (int r = 0; r < 4 * repeats + 2; ++r) {
        auto t0 = Clock::now();
        (void)avatar.decoders()->forward(descriptor, g.embed_geometry, g.embed_appearance, transforms);
        const double plain = ms_since(t0);
        t0 = Clock::now();
        (void)frozen.forward(descriptor, transforms);
        const double fast = ms_since(t0);
        if (r < 2) continue;
        t_decoders_plain.push_back(plain);
        t_decoders_frozen.push_back(fast);
      }
    }
    // Training-side stages forward + backward, wall clock, each on detached inputs that require
    // grad and a random cotangent: the three decoders, the 3x3 chain (with spd_from_raw) in
    // LibTorch ops against the one-op chain Avatar::pose runs under autograd, and the static
    // descriptor in LibTorch ops against its one-op loop, alternating.
    std::vector<double> t_train_decoders, t_train_chain, t_train_chain_fused, t_train_descriptor_ops,
        t_train_descriptor_loop;
    {
      const auto state = avatar.pose(pose, shape, trans);
      const auto leaf = [](const torch::Tensor& t) { return t.detach().clone().requires_grad_(true); };
      const auto descriptor = leaf(state.descriptor.defined() ? state.descriptor : torch::zeros({n, 0}));
      const auto transforms = leaf(torch::randn({n, 12}));
      const auto& g = avatar.gaussians();
      const auto eg = leaf(g.embed_geometry), ea = leaf(g.embed_appearance);
      const auto raw_g = leaf(torch::randn({n, 10}) * 0.1), raw_f = leaf(torch::randn({n, 13}) * 0.1);
      const auto rotations = leaf(g.rotations), log_scales = leaf(g.log_scales);
      const auto linear = leaf(torch::randn({n, 3, 3}));
      const auto cot_posed = torch::randn({n, 6}), cot_dx = torch::randn({n, 3});
      const auto lbs_means = leaf(state.lbs_means), joints = leaf(state.lbs.joints[0]);
      const auto backward_chain = [&](const handscs::CovarianceChain& chain) {
        ((chain.posed_upper * cot_posed).sum() + chain.dsigma.sum()).backward();
      };
      const auto& topology = avatar.topology();
      const double tau = config.scs.tau, eps = config.scs.norm_eps;
      for (int r = 0; r < repeats + 2; ++r) {
        const double decoders_ms = bench::ms_of([&] {
          const auto out = avatar.decoders()->outputs(descriptor, eg, ea, transforms);
          (out.geometry.sum() + (out.appearance * cot_dx).sum() + out.fusion.sum()).backward();
        });
        avatar.decoders()->zero_grad();
        const double chain_ms = bench::ms_of([&] {
          const auto offsets = handscs::offsets_from_outputs(raw_g, torch::zeros({n, 3}), raw_f);
          backward_chain(handscs::covariance_chain_ops(rotations, log_scales, offsets.dsigma, offsets.dsigma_f, linear));
        });
        const double chain_fused_ms = bench::ms_of([&] {
          backward_chain(handscs::covariance_chain(rotations, log_scales, handscs::spd_raw(raw_g),
                                                   handscs::spd_raw(raw_f), linear));
        });
        const double descriptor_ops_ms = bench::ms_of(
            [&] { handscs::static_descriptor(lbs_means, joints, topology, tau, eps).sum().backward(); });
        const double descriptor_loop_ms = bench::ms_of(
            [&] { handscs::static_descriptor_loop(lbs_means, joints, topology, tau, eps).sum().backward(); });
        if (r < 2) continue;
        t_train_decoders.push_back(decoders_ms);
        t_train_chain.push_back(chain_ms);
        t_train_chain_fused.push_back(chain_fused_ms);
        t_train_descriptor_ops.push_back(descriptor_ops_ms);
        t_train_descriptor_loop.push_back(descriptor_loop_ms);
      }
    }
    // The per-Gaussian 3x3 chain at inference, alternating in one process: the LibTorch ops (the
    // reference form) against avatar/covariance_chain.h.
    std::vector<double> t_chain_ops, t_chain_fused;
    {
      c10::InferenceMode guard;
      const auto& g = avatar.gaussians();
      const auto raw_g = torch::randn({n, 10}) * 0.1, raw_f = torch::randn({n, 13}) * 0.1;
      const auto linear = torch::randn({n, 3, 3});
      for (int r = 0; r < 4 * repeats + 2; ++r) {
        auto t0 = Clock::now();
        {
          const auto offsets = handscs::offsets_from_outputs(raw_g, torch::zeros({n, 3}), raw_f);
          (void)handscs::covariance_chain_ops(g.rotations, g.log_scales, offsets.dsigma,
                                              offsets.dsigma_f, linear);
        }
        const double ops = ms_since(t0);
        t0 = Clock::now();
        (void)handscs::covariance_chain(g.rotations, g.log_scales, handscs::spd_raw(raw_g),
                                        handscs::spd_raw(raw_f), linear);
        const double fused = ms_since(t0);
        if (r < 2) continue;
        t_chain_ops.push_back(ops);
        t_chain_fused.push_back(fused);
      }
    }
    // Skinning and the static descriptor at inference, alternating in one process: the LibTorch ops
    // (training's skinning; the descriptor's reference form) against hand/lbs_one_pose.h and
    // static_descriptor_loop.
    std::vector<double> t_lbs_ops, t_lbs_loops, t_static_ops, t_static_loop;
    {
      c10::InferenceMode guard;
      const auto state = avatar.pose(pose, shape, trans);
      const auto joints = state.lbs.joints[0];
      const auto& tau = config.scs.tau;
      const auto& eps = config.scs.norm_eps;
      for (int r = 0; r < 4 * repeats + 2; ++r) {
        const auto novel_pose = torch::randn({48}) * 0.2;
        auto t0 = Clock::now();
        (void)handscs::lbs(avatar.rig(), novel_pose.view({1, 48}), shape.view({1, 10}), trans.view({1, 3}));
        const double lbs_ops = ms_since(t0);
        t0 = Clock::now();
        (void)handscs::lbs_one_pose(avatar.rig(), novel_pose, shape, trans);
        const double lbs_loops = ms_since(t0);
        t0 = Clock::now();
        (void)handscs::static_descriptor(state.lbs_means, joints, avatar.topology(), tau, eps);
        const double static_ops = ms_since(t0);
        t0 = Clock::now();
        (void)handscs::static_descriptor_loop(state.lbs_means, joints, avatar.topology(), tau, eps);
        const double static_loop = ms_since(t0);
        if (r < 2) continue;
        t_lbs_ops.push_back(lbs_ops);
        t_lbs_loops.push_back(lbs_loops);
        t_static_ops.push_back(static_ops);
        t_static_loop.push_back(static_loop);
      }
    }
    nlohmann::json row;
    row["gaussians"] = n;
    row["inference_lbs_ms"] = {{"ops", median(t_lbs_ops)}, {"loops", median(t_lbs_loops)}};
    row["inference_static_descriptor_ms"] = {{"ops", median(t_static_ops)},
                                             {"loop", median(t_static_loop)}};
    row["inference_covariance_chain_ms"] = {{"ops", median(t_chain_ops)},
                                            {"fused", median(t_chain_fused)}};
    row["inference_decoders_ms"] = {{"plain", median(t_decoders_plain)},
                                    {"frozen", median(t_decoders_frozen)}};
    row["render_ms"] = median(t_render);
    row["render_fps"] = 1000.0 / median(t_render);
    row["render_culled_ms"] = median(t_render_culled);
    row["render_stage_ms"] = {{"pose", median(t_render_pose)}, {"rasterizer", median(t_render_raster)}};
    row["forward_ms"] = median(t_forward);
    row["backward_ms"] = median(t_backward);
    row["forward_backward_ms"] = median(t_forward) + median(t_backward);
    // train.cull's forward + backward (alternated with the above) and the share it decodes.
    row["forward_backward_culled_ms"] = median(t_culled);
    row["culled_decoded_fraction"] = decoded_fraction;
    row["stage_forward_ms"] = {{"lbs", median(t_lbs)},
                               {"scs", median(t_scs)},
                               {"decoders", median(t_dec)},
                               {"rasterizer", median(t_raster_fwd)}};
    row["rasterizer_backward_ms"] = median(t_raster_bwd);
    row["training_forward_backward_ms"] = {
        {"decoders", median(t_train_decoders)},
        {"covariance_chain", {{"ops", median(t_train_chain)}, {"fused", median(t_train_chain_fused)}}},
        {"static_descriptor", {{"ops", median(t_train_descriptor_ops)}, {"loop", median(t_train_descriptor_loop)}}}};
    row["other_backward_ms"] = median(t_backward) - median(t_raster_bwd);
    if (!no_train_step) {
      row["train_step"] = bench::time_train_steps(n, train_step);
      row["train_step_ms"] = row["train_step"].is_null() ? nlohmann::json() : row["train_step"]["step_ms"];
    }
    result["runs"].push_back(row);
  }
  std::printf("%s\n", result.dump(2).c_str());
  return 0;
}
