// handscs-bench-hands: what a second hand costs. For each Gaussian count N per hand, one hand
// against two side by side (the left one the right's mirror image, 6 cm along x, so they overlap
// in the view): render_ms, a novel pose's whole forward as handscs-render takes it (each hand
// posed, then one rasteriser call), and train_step_ms, one Trainer::step with every loss
// (train_step_timing.h, data.hand right against both on the same two-hand capture). Prints one
// JSON object. Usage:
//   handscs-bench-hands [--gaussians 3000,10000] [--threads 2] [--repeats 20]
//                       [--lpips-weights FILE] [--no-train-step] [--work-dir DIR]
#include <array>
#include <memory>
#include <sstream>

#include <CLI/CLI.hpp>
#include <c10/core/InferenceMode.h>
#include <nlohmann/json.hpp>
#include <torch/types.h>

#include "avatar/avatar.h"
#include "avatar/pose_memo.h"
#include "core/allocator.h"
#include "core/logging.h"
#include "core/threads.h"
#include "bench_timing.h"
#include "grown_avatar.h"
#include "train_step_timing.h"

namespace {

constexpr double kLeftOffsetX = 0.06;  // m: as the two-hand test capture, the hands overlap

// Median ms of a novel pose rendered with `hands` avatars (the right hand first), a new random pose
// per frame so nothing pose-dependent is reused; the hands posed side by side as handscs-render
// poses them, or one after the other.
double render_ms(std::vector<handscs::Avatar*> hands, const handscs::Camera& camera, int repeats,
                 bool side_by_side = true) {
  c10::InferenceMode guard;
  const auto shape = torch::zeros({10});
  std::array<std::unique_ptr<handscs::PoseMemo>, 2> memos;
  for (size_t k = 0; k < hands.size(); ++k) memos[k] = std::make_unique<handscs::PoseMemo>(*hands[k]);
  std::vector<double> times;
  for (int r = 0; r < repeats + 2; ++r) {
    const auto pose = torch::randn({48}) * 0.2;
    // The left hand: the right's pose mirrored (axis-angle (a, b, c) -> (a, -b, -c)).
    const auto mirrored = (pose.view({16, 3}) * torch::tensor({1.0f, -1.0f, -1.0f})).reshape({48});
    const std::array<torch::Tensor, 2> trans = {torch::zeros({3}),
                                                torch::tensor({float(kLeftOffsetX), 0.0f, 0.0f})};
    const auto t0 = bench::Clock::now();
    std::array<handscs::PoseMemo*, 2> memo_of{};
    std::array<handscs::HandPoseInput, 2> inputs{};
    for (size_t k = 0; k < hands.size(); ++k) {
      memo_of[k] = memos[k].get();
      inputs[k] = {(k == 0 ? pose : mirrored).data_ptr<float>(), shape.data_ptr<float>(),
                   trans[k].data_ptr<float>()};
    }
    std::vector<const handscs::PosedGaussians*> posed;
    if (side_by_side) {
      for (const handscs::AvatarState* state : handscs::pose_side_by_side(memo_of, inputs))
        if (state) posed.push_back(&state->posed);
    } else {
      for (size_t k = 0; k < hands.size(); ++k)
        posed.push_back(&memo_of[k]->pose(inputs[k].pose, inputs[k].shape, inputs[k].trans).posed);
    }
    (void)handscs::render_posed(handscs::join_posed(posed), camera, {});
    if (r >= 2) times.push_back(bench::ms_since(t0));
  }
  return bench::median(times);
}

}  // namespace

int main(int argc, char** argv) {
  handscs::log_to_stderr();  // stdout carries the JSON only
  handscs::keep_freed_memory_for_reuse();
  CLI::App app{"One hand against two: novel-pose render and training step (prints JSON)"};
  std::string counts = "3000,10000";
  int threads = 2, repeats = 20;
  bool no_train_step = false;
  std::string work_dir = "/tmp/handscs-bench-hands";
  bench::TrainStepOptions train_step;
  app.add_option("--gaussians", counts, "comma-separated Gaussian counts per hand");
  app.add_option("--threads", threads);
  app.add_option("--repeats", repeats, "timed repeats (median reported)");
  app.add_option("--lpips-weights", train_step.lpips_weights, "LPIPS weights for the training step");
  app.add_flag("--no-train-step", no_train_step, "skip the training step");
  app.add_option("--work-dir", work_dir, "where the training step's capture is written");
  CLI11_PARSE(app, argc, argv);
  handscs::set_threads(threads);
  train_step.repeats = repeats;
  if (!no_train_step) train_step.capture_dir = bench::make_train_step_capture(work_dir + "/capture", true);
  torch::manual_seed(0);
  const auto camera = bench::capture_camera(512, 334);

  nlohmann::json result = {{"threads", threads}, {"repeats", repeats}, {"width", camera.width},
                           {"height", camera.height}, {"blas", handscs::blas_in_use()},
                           {"load_average", bench::load_average()},
                           {"train_step_lpips", !train_step.lpips_weights.empty()}};
  std::stringstream list(counts);
  std::string item;
  while (std::getline(list, item, ',')) {
    const int64_t n = std::stoll(item);
    handscs::Avatar right(handscs::AvatarConfig{}, handscs::load_rig_source("builtin"));
    handscs::Avatar left(handscs::AvatarConfig{}, handscs::load_rig_source("builtin:left"));
    for (handscs::Avatar* avatar : {&right, &left}) {
      bench::grow(*avatar, n);
      bench::open_gates(*avatar);
    }
    const double one = render_ms({&right}, camera, repeats);
    const double two = render_ms({&right, &left}, camera, repeats);
    const double two_in_turn = render_ms({&right, &left}, camera, repeats, false);
    nlohmann::json row = {{"gaussians_per_hand", n},
                          {"render_ms_one_hand", one},
                          {"render_ms_two_hands", two},
                          {"render_ms_two_hands_posed_in_turn", two_in_turn},
                          {"render_fps_two_hands", 1000.0 / two},
                          {"render_ratio", two / one}};
    if (!no_train_step) {
      train_step.hand = handscs::CaptureConfig::Hands::right;
      const auto step_one = bench::time_train_steps(n, train_step);
      train_step.hand = handscs::CaptureConfig::Hands::both;
      const auto step_two = bench::time_train_steps(n, train_step);
      row["train_step_one_hand"] = step_one;
      row["train_step_two_hands"] = step_two;
      if (!step_one.is_null() && !step_two.is_null())
        row["train_step_ratio"] = step_two["mean_step_ms"].get<double>() / step_one["mean_step_ms"].get<double>();
    }
    result["counts"].push_back(row);
    spdlog::info("{} per hand: render {:.2f} -> {:.2f} ms", n, one, two);
  }
  std::cout << result.dump(2) << std::endl;
  return 0;
}
