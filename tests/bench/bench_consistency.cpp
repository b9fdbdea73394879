// handscs-bench-consistency: how often the inter-pose loss's candidate search (K nearest Gaussians
// in canonical space) finds the exact argmin_j |P_t^i - P_t-1^j|^2, on a trained avatar and its
// capture, for several K; and what each search costs. Pairs are random training frames, as the
// trainer's consecutive iterations are. Prints one JSON object. Usage:
//   handscs-bench-consistency --checkpoint RUN [--capture ROOT] [--k 16,32,64,128] [--pairs 20]
#include <torch/torch.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <iostream>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>

#include "core/config.h"
#include "core/threads.h"
#include "data/capture.h"
#include "train/avatar_state_io.h"
#include "train/checkpoint.h"
#include "train/consistency.h"
#include "train/evaluate.h"
#include "train/run_config.h"

namespace {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

torch::Tensor descriptor_of(handscs::Avatar& avatar, const handscs::FrameInfo& f) {
  auto tensor = [](const float* p, int64_t n) {
    return torch::from_blob(const_cast<float*>(p), {n}, torch::kFloat32).clone();
  };
  return avatar
      .pose(tensor(f.pose.data(), 48), tensor(f.shape.data(), 10), tensor(f.trans.data(), 3), true)
      .descriptor;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Inter-pose correspondence: candidate search against the exact argmin (JSON)"};
  std::string checkpoint, capture_root, ks = "8,16,32,64,128";
  int pairs = 20, threads = 2;
  uint64_t seed = 1;
  app.add_option("--checkpoint", checkpoint, "checkpoint file or run folder")->required();
  app.add_option("--capture", capture_root, "capture root (default: the stored config's)");
  app.add_option("--k", ks, "comma-separated candidate counts K");
  app.add_option("--pairs", pairs, "random pairs of training frames");
  app.add_option("--threads", threads);
  app.add_option("--seed", seed);
  CLI11_PARSE(app, argc, argv);
  handscs::set_threads(threads);
  torch::NoGradGuard no_grad;

  const std::string path = handscs::resolve_checkpoint_path(checkpoint);
  const auto ckpt = handscs::load_checkpoint(path);
  handscs::RunConfig config;
  handscs::config_from_json(ckpt.meta.at("config"), path + " (stored config)", config);
  if (!capture_root.empty()) config.data.root = capture_root;
  auto capture = handscs::Capture::open(config.data, "");
  auto avatar = handscs::restore_avatar(ckpt, config.model,
                                        handscs::load_rig_source(config.model.rig), path);
  const auto& frames = capture.train();

  std::vector<int64_t> k_values;
  std::stringstream list(ks);
  for (std::string item; std::getline(list, item, ',');) k_values.push_back(std::stoll(item));
  std::mt19937_64 rng(seed);
  std::uniform_int_distribution<size_t> pick(0, frames.size() - 1);

  std::map<int64_t, std::vector<double>> agreement, distance_agreement, ms;
  std::vector<double> exact_ms;
  const auto& means = avatar.gaussians().means;
  std::map<int64_t, torch::Tensor> candidates;
  for (int64_t k : k_values) candidates[k] = handscs::nearest_neighbours(means, k);
  for (int p = 0; p < pairs; ++p) {
    const auto& a = frames[pick(rng)];
    const auto* b = &frames[pick(rng)];
    while (b->pose_index == a.pose_index) b = &frames[pick(rng)];
    const auto query = descriptor_of(avatar, a), reference = descriptor_of(avatar, *b);
    auto t0 = Clock::now();
    const auto exact = handscs::correspond_exact(query, reference);
    exact_ms.push_back(ms_since(t0));
    const auto exact_d = (query - reference.index_select(0, exact)).pow(2).sum(1);
    for (int64_t k : k_values) {
      t0 = Clock::now();
      const auto match = handscs::correspond_candidates(query, reference, candidates[k]);
      ms[k].push_back(ms_since(t0));
      agreement[k].push_back(match.eq(exact).to(torch::kFloat64).mean().item<double>());
      // Ties: a different index at the same distance is as good a match.
      const auto d = (query - reference.index_select(0, match)).pow(2).sum(1);
      distance_agreement[k].push_back(d.le(exact_d).to(torch::kFloat64).mean().item<double>());
    }
  }
  auto mean = [](const std::vector<double>& v) {
    double s = 0;
    for (double x : v) s += x;
    return v.empty() ? 0.0 : s / v.size();
  };
  nlohmann::json out;
  out["checkpoint"] = path;
  out["gaussians"] = means.size(0);
  out["descriptor_dim"] = avatar.descriptor_dim();
  out["pairs"] = pairs;
  out["exact_ms_mean"] = mean(exact_ms);
  for (int64_t k : k_values) {
    out["candidates"][std::to_string(k)] = {
        {"agreement_mean", mean(agreement[k])},
        {"agreement_min", *std::min_element(agreement[k].begin(), agreement[k].end())},
        {"same_distance_mean", mean(distance_agreement[k])},
        {"ms_mean", mean(ms[k])}};
  }
  std::cout << out.dump(2) << std::endl;
  return 0;
}
