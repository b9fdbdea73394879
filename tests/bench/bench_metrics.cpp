// handscs-bench-metrics: images per second of PSNR, SSIM and LPIPS (forward, and forward+backward
// as training losses) on 512x334 pairs, for 1 and 2 threads. Prints one JSON object.
// Usage: handscs-bench-metrics [--lpips-weights FILE] [--repeats N] [--threads 1,2]
#include <functional>
#include <iostream>
#include <string>
#include <vector>

#include <ATen/ATen.h>
#include <CLI/CLI.hpp>
#include <c10/core/InferenceMode.h>
#include <nlohmann/json.hpp>
#include <torch/csrc/autograd/autograd.h>

#include "core/allocator.h"
#include "core/logging.h"
#include "core/threads.h"
#include "metrics/image_scorer.h"
#include "metrics/image_tensor.h"
#include "metrics/lpips.h"
#include "metrics/psnr.h"
#include "metrics/ssim.h"

#include "bench_timing.h"

namespace {

// Smooth random image [1, 3, H, W] in (0, 1).
torch::Tensor test_image(int64_t h, int64_t w, uint64_t seed) {
  at::manual_seed(seed);
  auto noise = at::rand({1, 3, h, w});
  auto kernel = at::ones({3, 1, 5, 5}) / 25.0;
  return 0.1 + 0.8 * at::conv2d(noise, kernel, {}, 1, 2, 1, 3);
}

// LPIPS-alex with random weights of the official shapes (same cost) when no file is given.
handscs::Lpips make_lpips(const std::string& path) {
  if (!path.empty()) {
    handscs::LpipsConfig config;
    config.weights = path;
    return handscs::Lpips(config);
  }
  const auto& spec = handscs::lpips_net_spec("alex");
  handscs::TensorDict weights;
  for (const auto& [key, shape] : handscs::lpips_weight_shapes(spec))
    weights[key] = at::rand(shape) * 0.01;
  return handscs::Lpips(spec, weights, "zero_one", "random");
}

}  // namespace

int main(int argc, char** argv) {
  handscs::log_to_stderr();  // stdout carries the JSON only
  handscs::keep_freed_memory_for_reuse();  // as the tools run (core/allocator.h)
  CLI::App app{"handscs-bench-metrics"};
  std::string weights;
  int repeats = 9;
  std::vector<int> thread_counts = {1, 2};
  app.add_option("--lpips-weights", weights, "LPIPS alex file (default: random weights, same cost)");
  app.add_option("--repeats", repeats, "timed repeats per measurement (median reported)");
  app.add_option("--threads", thread_counts, "thread counts to sweep")->delimiter(',');
  CLI11_PARSE(app, argc, argv);
  try {
    constexpr int64_t kHeight = 334, kWidth = 512;  // InterHand2.6M image size
    const int warmup = 2;
    const auto x = test_image(kHeight, kWidth, 1);
    const auto y = test_image(kHeight, kWidth, 2);
    const auto lpips = make_lpips(weights);
    handscs::EvalConfig eval_config;
    eval_config.lpips.weights = weights;
    nlohmann::json out;
    out["benchmark"] = "metrics";
    out["image"] = {{"height", kHeight}, {"width", kWidth}, {"channels", 3}, {"dtype", "float32"}};
    out["warmup"] = warmup;
    out["repeats"] = repeats;
    out["lpips_weights"] = weights.empty() ? "random (official alex shapes)" : weights;
    out["blas"] = handscs::blas_in_use();
    out["load_average_start"] = bench::load_average();
    out["results"] = nlohmann::json::array();
    for (int threads : thread_counts) {
      handscs::set_threads(threads);
      nlohmann::json row;
      row["threads"] = threads;
      auto record = [&](const std::string& name, const std::function<void()>& f, int n_repeats) {
        const bench::Timing t = bench::time_repeated(f, warmup, n_repeats);
        row[name] = {{"median_ms", t.median_ms}, {"min_ms", t.min_ms},
                     {"images_per_s", 1000.0 / t.median_ms}};
      };
      {
        c10::InferenceMode guard;
        record("psnr", [&] { handscs::psnr(x, y).item<float>(); }, repeats * 5);
        record("ssim_3dgs_float", [&] { handscs::ssim(x, y).item<float>(); }, repeats);
        const auto xd = x.to(at::kDouble), yd = y.to(at::kDouble);
        record("ssim_3dgs_double", [&] { handscs::ssim(xd, yd).item<double>(); }, repeats);
        record("lpips_alex", [&] { lpips.distance(x, y).item<float>(); }, repeats);
        // One AlexNet pass over one image (the five convs), for scale.
        record("alexnet_features_one_image", [&] { lpips.features(x); }, repeats);
      }
      record("ssim_loss_fwd_bwd", [&] {
        auto p = x.clone().set_requires_grad(true);
        auto loss = handscs::ssim_loss(p, y);
        torch::autograd::grad({loss}, {p});
      }, repeats);
      record("lpips_loss_fwd_bwd", [&] {
        auto p = x.clone().set_requires_grad(true);
        auto loss = handscs::lpips_loss(lpips, p, y);
        torch::autograd::grad({loss}, {p});
      }, repeats);
      if (!weights.empty()) {
        // handscs-eval's per-image cost after decoding: PSNR + SSIM (double) + LPIPS.
        const handscs::ImageScorer scorer(eval_config);
        const auto xh = handscs::bchw_to_hwc(x), yh = handscs::bchw_to_hwc(y);
        record("eval_scorer_all_metrics", [&] { scorer.score(xh, yh); }, repeats);
      }
      out["results"].push_back(row);
    }
    out["load_average_end"] = bench::load_average();
    std::cout << out.dump(2) << std::endl;
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "handscs-bench-metrics: " << e.what() << std::endl;
    return 1;
  }
}
