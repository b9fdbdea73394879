// handscs-bench-consistency: the inter-pose loss's correspondence search pi(i) = argmin_j
// |P_t^i - P_t-1^j|^2 on a trained avatar and its capture: how often the candidate search (K
// nearest Gaussians in canonical space) and the k-d tree (train/descriptor_tree.h) find the exact
// argmin (a double-precision GEMM over all pairs), and what each search costs, the GEMM in float
// as the trainer runs it included. Pairs are random training frames, as the trainer's consecutive
// iterations are. --gaussians resamples the avatar to other counts as densification does (clones
// of random Gaussians, moved by a normal step of their own scale). With --min-weight, the mean cost
// per step when pairs less similar than that skip the search (train.consistency.min_weight), and
// the share of the pairs' similarity weight those skipped pairs carried. Prints one JSON object:
//   handscs-bench-consistency --checkpoint RUN [--capture ROOT] [--k 16,32,64,128] [--pairs 20]
//                             [--gaussians 3000,10000,20000] [--min-weight 0.05]
#include <torch/types.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <chrono>
#include <iostream>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>

#include "core/allocator.h"
#include "core/config.h"
#include "core/logging.h"
#include "core/threads.h"
#include "data/capture.h"
#include "run/avatar_state_io.h"
#include "run/run_config.h"
#include "train/consistency.h"
#include "train/descriptor_tree.h"
#include "bench_timing.h"

namespace {

using bench::Clock;
using bench::median;
using bench::ms_since;
using bench::seconds_since;

torch::Tensor descriptor_of(handscs::Avatar& avatar, const handscs::FrameInfo& f) {
  auto tensor = [](const float* p, int64_t n) {
    return torch::from_blob(const_cast<float*>(p), {n}, torch::kFloat32).clone();
  };
  return avatar
      .pose(tensor(f.pose.data(), 48), tensor(f.shape.data(), 10), tensor(f.trans.data(), 3), true)
      .descriptor;
}

// The pose feature f(theta) of L_con's similarity weight (absolute pose, as the trainer uses).
torch::Tensor pose_feature_of(handscs::Avatar& avatar, const handscs::FrameInfo& f) {
  auto pose = torch::from_blob(const_cast<float*>(f.pose.data()), {48}, torch::kFloat32).clone();
  if (!avatar.config().flat_hand_mean)
    pose.slice(0, 3, 48) += avatar.rig().hands_mean.to(torch::kFloat32);
  return handscs::pose_feature(pose);
}

// The avatar's Gaussians resampled to `count` rows: its own rows first (while count allows), then
// clones of random rows displaced by N(0, scale^2) per axis, as 3DGS clones and splits.
void resample_gaussians(handscs::Avatar& avatar, int64_t count, uint64_t seed) {
  auto& g = avatar.gaussians();
  const int64_t n = g.size();
  auto gen = at::detail::createCPUGenerator(seed);
  const auto own = torch::arange(std::min(n, count), torch::kInt64);
  const auto extra = at::randint(n, {std::max<int64_t>(0, count - n)}, gen, torch::kInt64);
  const auto rows = torch::cat({own, extra});
  auto jitter = at::randn({count, 3}, gen, torch::kFloat32) * torch::exp(g.log_scales.index_select(0, rows));
  jitter.slice(0, 0, own.size(0)).zero_();
  for (auto& [name, tensor] : g.all()) *tensor = tensor->index_select(0, rows);
  g.means = g.means + jitter;
}

std::vector<int64_t> parse_list(const std::string& text) {
  std::vector<int64_t> out;
  std::stringstream list(text);
  for (std::string item; std::getline(list, item, ',');) out.push_back(std::stoll(item));
  return out;
}

double mean(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x;
  return v.empty() ? 0.0 : s / v.size();
}

}  // namespace

int main(int argc, char** argv) {
  handscs::log_to_stderr();  // stdout carries the JSON only
  handscs::keep_freed_memory_for_reuse();  // as the tools run (core/allocator.h)
  CLI::App app{"Inter-pose correspondence: candidate search against the exact argmin (JSON)"};
  std::string checkpoint, capture_root, ks = "8,16,32,64,128", counts;
  int pairs = 20, threads = 2;
  double min_weight = 0.05;
  uint64_t seed = 1;
  app.add_option("--checkpoint", checkpoint, "checkpoint file or run folder")->required();
  app.add_option("--capture", capture_root, "capture root (default: the stored config's)");
  app.add_option("--k", ks, "comma-separated candidate counts K");
  app.add_option("--pairs", pairs, "random pairs of training frames");
  app.add_option("--gaussians", counts,
                 "comma-separated Gaussian counts to resample the avatar to (default: as trained)");
  app.add_option("--min-weight", min_weight, "similarity below which a pair skips the search");
  app.add_option("--threads", threads);
  app.add_option("--seed", seed);
  bool timing_only = false;
  app.add_flag("--timing-only", timing_only,
               "skip the brute-force references (double and float GEMM, minutes at 20k): time the "
               "tree and the candidates only, without exact shares or agreement");
  CLI11_PARSE(app, argc, argv);
  handscs::set_threads(threads);
  torch::NoGradGuard no_grad;

  // The avatar as trained (its stored config and its hand's rig: run/avatar_state_io.h).
  handscs::TrainedAvatar opened = handscs::open_trained_avatar(checkpoint);
  const std::string& path = opened.path;
  handscs::RunConfig& config = opened.config;
  handscs::Avatar& avatar = opened.avatar;
  if (!capture_root.empty()) config.data.root = capture_root;
  auto capture = handscs::Capture::open(config.data, "");
  const auto& frames = capture.train();
  const std::vector<int64_t> k_values = parse_list(ks);
  std::vector<int64_t> sizes = parse_list(counts);
  if (sizes.empty()) sizes.push_back(avatar.gaussians().size());
  const handscs::GaussianState trained = avatar.gaussians();

  nlohmann::json out;
  out["checkpoint"] = path;
  out["trained_gaussians"] = trained.size();
  out["descriptor_dim"] = avatar.descriptor_dim();
  out["pairs"] = pairs;
  out["threads"] = threads;
  for (int64_t size : sizes) {
    avatar.gaussians() = trained;
    resample_gaussians(avatar, size, seed);
    std::mt19937_64 rng(seed);
    std::uniform_int_distribution<size_t> pick(0, frames.size() - 1);
    std::map<int64_t, std::vector<double>> agreement, distance_agreement, ms;
    std::vector<double> gemm_ms, tree_ms, tree_exact, gemm_float_exact, weights, step_ms;
    const auto& means = avatar.gaussians().means;
    std::map<int64_t, torch::Tensor> candidates;
    for (int64_t k : k_values) candidates[k] = handscs::nearest_neighbours(means, k);
    const auto guess = torch::arange(size, torch::kInt64);
    for (int p = 0; p < pairs; ++p) {
      const auto& a = frames[pick(rng)];
      const auto* b = &frames[pick(rng)];
      while (b->pose_index == a.pose_index) b = &frames[pick(rng)];
      const auto query = descriptor_of(avatar, a), reference = descriptor_of(avatar, *b);
      weights.push_back(handscs::pose_similarity(pose_feature_of(avatar, a),
                                                 pose_feature_of(avatar, *b), config.train.consistency.delta));
      // Brute force in double: the minimum distance of every row (ties: any row at it is exact).
      torch::Tensor truth, best;
      const auto q64 = query.to(torch::kFloat64), r64 = reference.to(torch::kFloat64);
      if (!timing_only) {
        truth = handscs::correspond_exact(q64, r64);
        best = (q64 - r64.index_select(0, truth)).pow(2).sum(1);
      }
      const auto share = [&](const torch::Tensor& match) {
        if (timing_only) return std::nan("");
        const auto d = (q64 - r64.index_select(0, match)).pow(2).sum(1);
        return d.le(best * (1 + 1e-6)).to(torch::kFloat64).mean().item<double>();
      };
      auto t0 = Clock::now();
      if (!timing_only) {
        const auto gemm = handscs::correspond_exact(query, reference);
        gemm_ms.push_back(ms_since(t0));
        gemm_float_exact.push_back(share(gemm));
      }
      t0 = Clock::now();
      const auto tree = handscs::DescriptorTree(reference).nearest(query, guess);
      tree_ms.push_back(ms_since(t0));
      step_ms.push_back(weights.back() >= min_weight ? tree_ms.back() : 0.0);
      tree_exact.push_back(share(tree));
      for (int64_t k : k_values) {
        t0 = Clock::now();
        const auto match = handscs::correspond_candidates(query, reference, candidates[k]);
        ms[k].push_back(ms_since(t0));
        agreement[k].push_back(timing_only ? std::nan("")
                                           : match.eq(truth).to(torch::kFloat64).mean().item<double>());
        distance_agreement[k].push_back(share(match));
      }
    }
    nlohmann::json row;
    row["gaussians"] = size;
    row["gemm_float"] = {{"ms_median", median(gemm_ms)}, {"exact_share_mean", mean(gemm_float_exact)}};
    row["tree"] = {{"ms_median", median(tree_ms)},
                   {"exact_share_mean", mean(tree_exact)},
                   {"exact_share_min", *std::min_element(tree_exact.begin(), tree_exact.end())}};
    double skipped_weight = 0, total_weight = 0;
    int skipped = 0;
    for (double w : weights) {
      total_weight += w;
      if (w < min_weight) skipped_weight += w, ++skipped;
    }
    row["tree_with_min_weight"] = {{"min_weight", min_weight},
                                   {"ms_mean_per_step", mean(step_ms)},
                                   {"skipped_share", double(skipped) / weights.size()},
                                   {"skipped_weight_share", skipped_weight / total_weight}};
    row["pairs_weight_and_tree_ms"] = nlohmann::json::array();
    for (size_t p = 0; p < weights.size(); ++p)
      row["pairs_weight_and_tree_ms"].push_back({weights[p], tree_ms[p]});
    for (int64_t k : k_values) {
      row["candidates"][std::to_string(k)] = {
          {"agreement_mean", mean(agreement[k])},
          {"agreement_min", *std::min_element(agreement[k].begin(), agreement[k].end())},
          {"same_distance_mean", mean(distance_agreement[k])},
          {"ms_median", median(ms[k])}};
    }
    out["sizes"].push_back(row);
  }
  std::cout << out.dump(2) << std::endl;
  return 0;
}
