// Keypoint fit benchmark: accuracy and speed of fitting the built-in hand to 3D keypoints. Poses
// come from the synthetic capture generator (its range-of-motion cycle and its gestures, each
// frame with the capture's shape and its per-frame jitter); their MANO21 joints, with and without
// Gaussian noise, are fitted as one sequence (one shared shape), and the fit is compared with the
// truth: joints, mesh vertices, the bend of every finger joint. Then the time per frame of the
// sequence fit. Prints one JSON object. --set changes the fit's settings (docs/FIT.md's keys);
// --one-shape gives every frame the first frame's shape, to tell what the shared shape costs.
#include <ATen/Parallel.h>

#include <CLI/CLI.hpp>
#include <cmath>
#include <iostream>
#include <nlohmann/json.hpp>
#include <random>

#include "core/cli.h"
#include "core/config.h"
#include "core/logging.h"
#include "fit/fit_command.h"
#include "hand/joint_order.h"
#include "hand/keypoint_fit.h"
#include "hand/lbs_one_pose.h"
#include "hand/procedural_hand.h"
#include "synth/gestures.h"
#include "synth/motion.h"

#include "bench_timing.h"

using namespace handscs;
using nlohmann::json;

namespace {

torch::Tensor f64(const double* v, int n) {
  return torch::tensor(std::vector<double>(v, v + n), torch::kFloat64);
}

torch::Tensor vertices_of(const Rig& rig, const JointParams& p) {
  return lbs_one_pose(rig, f64(p.pose.data(), 48), f64(p.shape.data(), 10), f64(p.trans.data(), 3),
                      LbsOptions{true}).vertices[0];
}

double percentile(std::vector<double> v, double q) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v[static_cast<size_t>(q * (v.size() - 1))];
}

json round_trip(const Rig& rig, const JointModel& model, const std::vector<SynthPose>& poses, double noise_mm,
                uint64_t seed, const KeypointFitConfig& config) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, noise_mm * 1e-3);
  std::vector<HandKeypoints> frames;
  std::vector<JointParams> truth;
  for (const SynthPose& s : poses) {
    JointParams p;
    p.pose = s.pose;
    p.shape = s.shape;
    p.trans = {0.0, 0.0, 1.0};
    truth.push_back(p);
    HandKeypoints k;
    joint_positions(model, p, k.joints.data());
    for (double& v : k.joints) v += noise(rng);
    k.valid.fill(1);
    frames.push_back(k);
  }
  const auto start = bench::Clock::now();
  const std::vector<HandFit> fits = fit_keypoint_sequence(model, frames, config);
  const double ms = bench::ms_since(start);
  std::vector<double> residual, joint_error, vertex_error, bend_error;
  double worst_bend = -1;
  std::string worst_bend_joint;
  for (size_t f = 0; f < poses.size(); ++f) {
    std::array<double, 63> true_joints;
    joint_positions(model, truth[f], true_joints.data());
    for (int j = 0; j < 21; ++j) {
      residual.push_back(fits[f].residual_mm[j]);
      double d2 = 0;
      for (int c = 0; c < 3; ++c) d2 += std::pow(fits[f].joints[3 * j + c] - true_joints[3 * j + c], 2);
      joint_error.push_back(1e3 * std::sqrt(d2));
    }
    const auto want = joint_bend_angles(true_joints.data()), got = joint_bend_angles(fits[f].joints.data());
    for (int j = 0; j < 15; ++j) {
      bend_error.push_back(std::fabs(want[j] - got[j]) * 180.0 / M_PI);
      if (bend_error.back() > worst_bend) {
        worst_bend = bend_error.back();
        worst_bend_joint = kMano21Names[j + 1];  // bend angle j is rig joint j + 1's
      }
    }
    const auto d = (vertices_of(rig, fits[f].params) - vertices_of(rig, truth[f])).norm(2, 1) * 1e3;
    const auto dv = d.contiguous();
    vertex_error.insert(vertex_error.end(), dv.data_ptr<double>(), dv.data_ptr<double>() + dv.numel());
  }
  auto mean = [](const std::vector<double>& v) {
    double s = 0;
    for (double x : v) s += x;
    return v.empty() ? 0.0 : s / v.size();
  };
  return {{"noise_mm", noise_mm},
          {"frames", poses.size()},
          {"residual_mean_mm", mean(residual)},
          {"joint_error_mean_mm", mean(joint_error)},
          {"joint_error_p95_mm", percentile(joint_error, 0.95)},
          {"vertex_error_mean_mm", mean(vertex_error)},
          {"vertex_error_p95_mm", percentile(vertex_error, 0.95)},
          {"bend_error_mean_deg", mean(bend_error)},
          {"bend_error_max_deg", percentile(bend_error, 1.0)},
          {"bend_error_max_joint", worst_bend_joint},
          {"bend_error_p99_deg", percentile(bend_error, 0.99)},
          {"fit_ms_per_frame", ms / poses.size()}};
}

}  // namespace

int main(int argc, char** argv) {
  log_to_stderr();  // stdout carries the JSON only
  CLI::App app{"handscs-bench-fit: keypoint fit accuracy (synthetic poses, with and without noise) and time per frame "
               "(JSON on stdout)"};
  CommonOptions common;
  common.log_level = "warn";
  int frames = 200, repeats = 5;
  bool one_shape = false;
  add_common_options(app, common, true);
  app.add_option("--frames", frames, "frames of each pose source");
  app.add_flag("--one-shape", one_shape, "every frame takes the first frame's shape (no per-frame jitter)");
  app.add_option("--repeats", repeats, "timed runs of the sequence fit (median reported)");
  CLI11_PARSE(app, argc, argv);
  try {
    start_up(common, "handscs-bench-fit");
    const Rig rig = make_procedural_hand(Handedness::right);
    const JointModel model = make_joint_model(rig);
    const KeypointFitConfig config = load_config<FitCommandConfig>("", common.overrides).fit;
    std::vector<SynthPose> rom = make_rom_poses(rig, frames, 1);
    std::vector<SynthPose> gestures = make_gesture_poses(rig, frames, 0, 2, nullptr);
    if (one_shape)
      for (auto* poses : {&rom, &gestures})
        for (SynthPose& s : *poses) s.shape = poses->front().shape;
    json accuracy = json::array();
    for (const auto& [name, poses] : {std::pair{"range_of_motion", &rom}, std::pair{"gestures", &gestures}})
      for (double noise : {0.0, 5.0}) {
        json row = round_trip(rig, model, *poses, noise, 7, config);
        row["poses"] = name;
        accuracy.push_back(row);
      }
    // Speed: the gesture sequence with 5 mm noise, fitted `repeats` times after one warm-up.
    std::vector<double> ms;
    for (int r = 0; r <= repeats; ++r) {
      const double t = round_trip(rig, model, gestures, 5.0, 7, config)["fit_ms_per_frame"];
      if (r > 0) ms.push_back(t);
    }
    const json report = {{"benchmark", "fit"},
                         {"rig", "builtin"},
                         {"threads", at::get_num_threads()},
                         {"settings", common.overrides},
                         {"one_shape", one_shape},
                         {"load_average", bench::load_average()},
                         {"accuracy", accuracy},
                         {"speed", {{"frames", frames}, {"repeats", repeats},
                                    {"ms_per_frame_median", bench::median(ms)},
                                    {"ms_per_frame_min", *std::min_element(ms.begin(), ms.end())}}}};
    std::cout << report.dump(2) << std::endl;
  } catch (const std::exception& e) {
    std::cerr << e.what() << std::endl;
    return 1;
  }
  return 0;
}
