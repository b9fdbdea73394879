// handscs-bench-refine: whether training-pose refinement (train.pose_refine) moves the
// annotated poses towards the poses the synthetic capture was rendered with. The generator is
// deterministic, so the rendered poses are recomputed from the preset (no rendering); the run's
// pose_refine.csv holds the learned corrections. Per refined training pose: the rotation angle
// between annotated and rendered pose of each finger joint and of the global orientation, and the
// translation error, before and after the correction. Prints one JSON object. Usage:
//   handscs-bench-refine --run RUN [--preset real_demo]
#include <torch/types.h>

#include <CLI/CLI.hpp>
#include <cmath>
#include <fstream>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

#include "core/allocator.h"
#include "core/config.h"
#include "core/logging.h"
#include "data/capture.h"
#include "hand/lbs.h"
#include "run/run_config.h"
#include "synth/capture.h"
#include "synth/config.h"

namespace {

struct Correction {
  std::array<double, 48> pose{};
  std::array<double, 3> trans{};  // m
};

std::map<int, Correction> read_corrections(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot open (was the run trained with pose refinement?)");
  std::map<int, Correction> out;
  std::string line;
  std::getline(in, line);  // header
  while (std::getline(in, line)) {
    std::stringstream fields(line);
    std::vector<double> v;
    for (std::string f; std::getline(fields, f, ',');) v.push_back(std::stod(f));
    if (v.size() != 5 + 51) throw std::runtime_error(path + ": expected 56 columns, got " + std::to_string(v.size()));
    Correction c;
    for (int k = 0; k < 48; ++k) c.pose[k] = v[5 + k];
    for (int k = 0; k < 3; ++k) c.trans[k] = v[53 + k];
    out[static_cast<int>(v[0])] = c;
  }
  return out;
}

// Rotation angle (deg) between the axis-angle rotations a and b of each of the 16 joints.
std::vector<double> joint_angles(const torch::Tensor& a, const torch::Tensor& b) {
  const auto ra = handscs::rodrigues(a.reshape({16, 3})), rb = handscs::rodrigues(b.reshape({16, 3}));
  const auto trace = ra.transpose(1, 2).matmul(rb).diagonal(0, 1, 2).sum(1);
  const auto angle = ((trace - 1) / 2).clamp(-1, 1).acos() * (180.0 / M_PI);
  return std::vector<double>(angle.data_ptr<double>(), angle.data_ptr<double>() + 16);
}

}  // namespace

int main(int argc, char** argv) {
  handscs::log_to_stderr();  // stdout carries the JSON only
  handscs::keep_freed_memory_for_reuse();  // as the tools run (core/allocator.h)
  CLI::App app{"Training-pose refinement against the rendered poses of a synthetic capture (JSON)"};
  std::string run, preset = "real_demo";
  app.add_option("--run", run, "run folder trained with train.pose_refine.enabled")->required();
  app.add_option("--preset", preset, "synthetic capture preset the run was trained on");
  CLI11_PARSE(app, argc, argv);
  torch::NoGradGuard no_grad;

  const auto config = handscs::load_config<handscs::RunConfig>(run + "/config.json", {});
  const auto capture = handscs::Capture::open(config.data, "");
  const auto corrections = read_corrections(run + "/pose_refine.csv");
  const auto scene = handscs::make_synth_scene(handscs::synth_preset(preset));
  std::map<std::pair<std::string, int64_t>, const handscs::SynthFrame*> rendered;
  for (const auto& f : scene.frames) rendered[{f.seq_name, f.frame_idx}] = &f;
  const auto hands_mean = scene.rig.hands_mean.to(torch::kFloat64);

  double joints_before = 0, joints_after = 0, global_before = 0, global_after = 0;
  double trans_before = 0, trans_after = 0;
  int poses = 0, improved = 0, joint_count = 0;
  std::map<int, bool> seen;
  for (const auto& frame : capture.train()) {
    const auto it = corrections.find(frame.pose_index);
    if (it == corrections.end() || seen[frame.pose_index]) continue;
    seen[frame.pose_index] = true;
    const auto r = rendered.find({frame.seq_name, frame.frame_idx});
    if (r == rendered.end()) throw std::runtime_error("frame " + frame.seq_name + "/" + std::to_string(frame.frame_idx) + " is not in preset " + preset);
    // Everything in the annotation's space: rendered absolute pose minus hands_mean.
    auto truth = torch::tensor(std::vector<double>(r->second->absolute.pose.begin(), r->second->absolute.pose.end()), torch::kFloat64);
    if (!config.model.flat_hand_mean) truth.slice(0, 3, 48) -= hands_mean;
    const auto annotated = torch::tensor(std::vector<double>(frame.pose.begin(), frame.pose.end()), torch::kFloat64);
    const auto refined = annotated + torch::tensor(std::vector<double>(it->second.pose.begin(), it->second.pose.end()), torch::kFloat64);
    const auto before = joint_angles(annotated, truth), after = joint_angles(refined, truth);
    double pose_before = 0, pose_after = 0;
    for (int j = 1; j < 16; ++j) {
      joints_before += before[j] * before[j];
      joints_after += after[j] * after[j];
      pose_before += before[j] * before[j];
      pose_after += after[j] * after[j];
      ++joint_count;
    }
    global_before += before[0] * before[0];
    global_after += after[0] * after[0];
    double tb = 0, ta = 0;
    for (int d = 0; d < 3; ++d) {
      const double err = frame.trans[d] - r->second->trans[d];
      tb += err * err;
      ta += (err + it->second.trans[d]) * (err + it->second.trans[d]);
    }
    trans_before += tb;
    trans_after += ta;
    improved += pose_after < pose_before ? 1 : 0;
    ++poses;
  }
  if (poses == 0) throw std::runtime_error(run + ": no refined training pose found in the capture");
  nlohmann::json out;
  out["run"] = run;
  out["refined_poses"] = poses;
  out["finger_joint_rms_deg"] = {{"annotated", std::sqrt(joints_before / joint_count)},
                                 {"refined", std::sqrt(joints_after / joint_count)}};
  out["global_rms_deg"] = {{"annotated", std::sqrt(global_before / poses)},
                           {"refined", std::sqrt(global_after / poses)}};
  out["translation_rms_mm"] = {{"annotated", 1000 * std::sqrt(trans_before / poses)},
                               {"refined", 1000 * std::sqrt(trans_after / poses)}};
  out["poses_with_smaller_finger_error"] = improved;
  std::cout << out.dump(2) << std::endl;
  return 0;
}
