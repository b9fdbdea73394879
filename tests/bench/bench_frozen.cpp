// handscs-bench-frozen: what the frozen decoders (avatar/frozen_decoders.h) cost in error. A trained
// avatar renders held-out frames of its own capture twice, through the training path (autograd on:
// the decoders as trained) and through the inference path handscs-eval and handscs-render take
// (frozen decoders); prints PSNR of one against the other and each one's PSNR / SSIM / LPIPS
// against the ground truth, with the per-frame forward time of both. The same for the inference
// path with the back-facing Gaussians culled (avatar/facing_cull.h; measured only, not offered by
// handscs-render) against the frozen path. Prints one JSON object. Usage:
//   handscs-bench-frozen --checkpoint RUN [--max-images 150] [--lpips-weights FILE] [--threads 2]
#include <cmath>
#include <cstdio>
#include <filesystem>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <torch/types.h>

#include "core/allocator.h"
#include "core/logging.h"
#include "core/threads.h"
#include "data/capture.h"
#include "metrics/image_scorer.h"
#include "metrics/psnr.h"
#include "run/avatar_state_io.h"
#include "run/run_config.h"
#include "bench_timing.h"

namespace {

using bench::Clock;
using bench::median;
using bench::ms_since;

struct Sums {
  double psnr = 0, ssim = 0, lpips = 0;
  void add(const handscs::ImageScores& s) {
    psnr += s.psnr;
    ssim += s.ssim;
    lpips += s.lpips.value_or(0);
  }
  nlohmann::json mean(int64_t n, bool lpips_on) const {
    return {{"psnr", psnr / n}, {"ssim", ssim / n}, {"lpips", lpips_on ? nlohmann::json(lpips / n) : nlohmann::json()}};
  }
};

}  // namespace

int main(int argc, char** argv) {
  handscs::log_to_stderr();  // stdout carries the JSON only
  handscs::keep_freed_memory_for_reuse();
  CLI::App app{"Frozen decoders against the training path on held-out frames (prints JSON)"};
  std::string checkpoint, lpips_weights;
  int64_t max_images = 150;
  int threads = 2;
  app.add_option("--checkpoint", checkpoint, "checkpoint file or run folder")->required();
  app.add_option("--max-images", max_images, "held-out frames, evenly spaced (0 = all)");
  app.add_option("--lpips-weights", lpips_weights, "LPIPS weights (without: LPIPS not reported)");
  app.add_option("--threads", threads);
  CLI11_PARSE(app, argc, argv);
  handscs::set_threads(threads);

  handscs::TrainedAvatar trained = handscs::open_trained_avatar(checkpoint);
  handscs::RunConfig& config = trained.config;
  handscs::Avatar& avatar = trained.avatar;
  config.eval.lpips.weights = lpips_weights;
  const auto cache = std::filesystem::temp_directory_path() / "handscs-bench-frozen-cache";
  handscs::Capture capture = handscs::Capture::open(config.data, cache.string());
  const handscs::ImageScorer scorer(config.eval);

  auto frames = capture.test();
  if (max_images > 0 && static_cast<int64_t>(frames.size()) > max_images) {
    std::vector<handscs::FrameInfo> subset;
    for (int64_t k = 0; k < max_images; ++k) subset.push_back(frames[k * frames.size() / max_images]);
    frames = subset;
  }
  const auto& bg = config.eval.background;
  const auto bg_tensor = torch::tensor({float(bg[0]), float(bg[1]), float(bg[2])});
  handscs::RasterSettings settings;
  settings.background = {float(bg[0]), float(bg[1]), float(bg[2])};
  Sums exact_sums, frozen_sums, culled_sums;
  double mse_sum = 0, worst_psnr = INFINITY, culled_mse_sum = 0, culled_worst_psnr = INFINITY;
  double decoded_share = 0;
  std::vector<double> exact_ms, frozen_ms, culled_ms;
  for (const auto& frame : frames) {
    auto sample = capture.load(frame, /*full_image=*/true);
    const auto mask = sample.mask.to(torch::kFloat32).unsqueeze(2);
    const auto gt = sample.image.to(torch::kFloat32).div(255.0) * mask + bg_tensor * (1 - mask);
    const auto pose = torch::tensor(std::vector<float>(frame.pose.begin(), frame.pose.end()));
    const auto shape = torch::tensor(std::vector<float>(frame.shape.begin(), frame.shape.end()));
    const auto trans = torch::tensor(std::vector<float>(frame.trans.begin(), frame.trans.end()));
    torch::Tensor exact, frozen, culled;
    {
      torch::AutoGradMode grad(true);  // the decoders as trained
      const auto t0 = Clock::now();
      exact = avatar.forward(pose, shape, trans, sample.camera, settings).render.rgb.detach();
      exact_ms.push_back(ms_since(t0));
    }
    {
      c10::InferenceMode guard;  // what handscs-eval and handscs-render run
      const auto t0 = Clock::now();
      frozen = avatar.forward(pose, shape, trans, sample.camera, settings).render.rgb;
      frozen_ms.push_back(ms_since(t0));
    }
    {
      c10::InferenceMode guard;
      handscs::FacingCull cull;
      cull.camera_centres = {sample.camera.centre()};
      const auto t0 = Clock::now();
      const auto state = avatar.pose(pose, shape, trans, false, &cull);
      culled = handscs::render_posed(state.posed, sample.camera, settings).rgb;
      culled_ms.push_back(ms_since(t0));
      decoded_share += state.decoded_fraction();
    }
    exact = exact.clamp(0, 1);
    frozen = frozen.clamp(0, 1);
    const double mse = (frozen - exact).pow(2).mean().item<double>();
    mse_sum += mse;
    worst_psnr = std::min(worst_psnr, handscs::psnr_from_mse(mse));
    culled = culled.clamp(0, 1);
    const double culled_mse = (culled - frozen).pow(2).mean().item<double>();
    culled_mse_sum += culled_mse;
    culled_worst_psnr = std::min(culled_worst_psnr, handscs::psnr_from_mse(culled_mse));
    exact_sums.add(scorer.score(exact, gt));
    frozen_sums.add(scorer.score(frozen, gt));
    culled_sums.add(scorer.score(culled, gt));
  }
  const auto n = static_cast<int64_t>(frames.size());
  const bool lpips_on = scorer.has_lpips();
  nlohmann::json out;
  out["checkpoint"] = trained.path;
  out["frames"] = n;
  out["gaussians"] = avatar.gaussians().size();
  out["threads"] = threads;
  out["frozen_vs_exact"] = {{"psnr_of_mean_mse", handscs::psnr_from_mse(mse_sum / n)},
                            {"worst_frame_psnr", worst_psnr}};
  out["exact_vs_gt"] = exact_sums.mean(n, lpips_on);
  out["frozen_vs_gt"] = frozen_sums.mean(n, lpips_on);
  out["culled_vs_frozen"] = {{"psnr_of_mean_mse", handscs::psnr_from_mse(culled_mse_sum / n)},
                              {"worst_frame_psnr", culled_worst_psnr},
                              {"decoded_share", decoded_share / n}};
  out["culled_vs_gt"] = culled_sums.mean(n, lpips_on);
  out["forward_ms"] = {{"exact", median(exact_ms)}, {"frozen", median(frozen_ms)}, {"culled", median(culled_ms)}};
  std::printf("%s\n", out.dump(2).c_str());
  return 0;
}
