// LBS benchmark: forward and forward+backward time of lbs() on the built-in hand for batch sizes 1
// and 8, float32 and float64, and the time to generate the built-in hand. Prints one JSON object
// (warm-up, repeats, median and min in ms).
#include <ATen/ATen.h>
#include <ATen/Parallel.h>
#include <torch/csrc/autograd/autograd.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <iostream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/cli.h"
#include "core/logging.h"
#include "hand/lbs.h"
#include "hand/procedural_hand.h"

#include "bench_timing.h"

namespace {

template <class F>
nlohmann::json time_it(F&& f, int warmup, int repeats) {
  const bench::Timing t = bench::time_repeated(f, warmup, repeats);
  return {{"median_ms", t.median_ms}, {"min_ms", t.min_ms}};
}

}  // namespace

int main(int argc, char** argv) {
  handscs::log_to_stderr();  // stdout carries the JSON only
  CLI::App app{"handscs-bench-lbs: LBS forward / backward timings (JSON on stdout)"};
  handscs::CommonOptions common;
  common.log_level = "warn";
  int warmup = 5, repeats = 50;
  handscs::add_common_options(app, common, false);
  app.add_option("--warmup", warmup, "untimed runs first");
  app.add_option("--repeats", repeats, "timed runs");
  CLI11_PARSE(app, argc, argv);
  try {
    handscs::start_up(common, "handscs-bench-lbs");
    const handscs::Rig rig = handscs::make_procedural_hand();
    const nlohmann::json generate = time_it([] { handscs::make_procedural_hand(); }, 1, 10);
    nlohmann::json results = nlohmann::json::array();
    for (auto dtype : {torch::kFloat32, torch::kFloat64})
      for (int64_t batch : {1, 8}) {
        torch::manual_seed(0);
        const auto options = torch::TensorOptions().dtype(dtype);
        torch::Tensor pose = (torch::randn({batch, 48}, options) * 0.3).requires_grad_(true);
        torch::Tensor shape = torch::randn({batch, 10}, options).requires_grad_(true);
        torch::Tensor trans = torch::zeros({batch, 3}, options).requires_grad_(true);
        const torch::Tensor cotangent = torch::randn({batch, rig.num_vertices(), 3}, options);
        nlohmann::json forward = time_it(
            [&] {
              torch::NoGradGuard no_grad;
              handscs::lbs(rig, pose, shape, trans);
            },
            warmup, repeats);
        nlohmann::json backward = time_it(
            [&] {
              const handscs::LbsOutput out = handscs::lbs(rig, pose, shape, trans);
              torch::autograd::backward({out.vertices}, {cotangent});
            },
            warmup, repeats);
        results.push_back({{"dtype", dtype == torch::kFloat32 ? "float32" : "float64"},
                           {"batch", batch},
                           {"forward", forward},
                           {"forward_backward", backward}});
      }
    const nlohmann::json report = {{"benchmark", "lbs"},
                                   {"rig", "builtin"},
                                   {"vertices", rig.num_vertices()},
                                   {"threads", at::get_num_threads()},
                                   {"warmup", warmup},
                                   {"repeats", repeats},
                                   {"generate_builtin", generate},
                                   {"results", results}};
    std::cout << report.dump(2) << std::endl;
  } catch (const std::exception& e) {
    std::cerr << e.what() << std::endl;
    return 1;
  }
  return 0;
}
