// Helpers shared by the metrics tests: the shared oracle pairs, temp folders, error capture and a
// finite-difference gradient checker (central differences in double precision).
//
// Include this header FIRST in every metrics test, instead of <catch2/catch.hpp>: Debian's LibTorch
// is built with glog, whose CHECK macro (c10/util/Logging.h) silently replaces Catch2's CHECK when a
// torch header comes after catch.hpp (a passing glog CHECK is not counted, a failing one aborts).
// Here the torch headers come first, glog's CHECK is undefined, and Catch2 defines its own.
#pragma once

#include <sys/wait.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include <ATen/ATen.h>
#include <opencv2/imgcodecs.hpp>
#include <torch/csrc/autograd/autograd.h>
#include <torch/types.h>

#include "catch_after_torch.h"

#include "core/atomic_file.h"
#include "core/config.h"
#include "metrics/image_tensor.h"
#include "metrics/lpips.h"
#include "metrics/ssim.h"
#include "test_support.h"

namespace metrics_test {

// handscs-eval run as a user runs it: its exit status and everything it printed.
struct RunResult {
  int status = -1;
  std::string output;  // stdout and stderr
};

inline RunResult run_eval(const std::string& args, const std::string& dir) {
  const std::string binary = std::string(HANDSCS_BIN_DIR) + "/handscs-eval";
  INFO("build handscs-eval first: " + binary);
  REQUIRE(std::filesystem::exists(binary));
  const std::string log = dir + "/log.txt";
  const int raw = std::system((binary + " --threads 2 " + args + " > " + log + " 2>&1").c_str());
  return {WIFEXITED(raw) ? WEXITSTATUS(raw) : -1, handscs::read_file(log)};
}

// The SSIM config of the variant a config file names ("3dgs", "valid", "matlab"), read the way
// config files are (an unknown name is an Error naming it).
inline handscs::SsimConfig ssim_variant_config(const std::string& name) {
  handscs::SsimConfig config;
  auto json = handscs::config_to_json(config);
  json["variant"] = name;
  handscs::config_from_json(json, "ssim", config);
  return config;
}

inline std::string shared_dir() { return HANDSCS_SHARED_DIR; }
inline std::string pairs_dir() { return shared_dir() + "/testdata/metric_pairs"; }
inline std::string lpips_alex_path() { return handscs_test::kLpipsAlexWeights; }

// LPIPS with the shared AlexNet weights.
inline handscs::Lpips load_alex() {
  handscs::LpipsConfig config;
  config.weights = lpips_alex_path();
  return handscs::Lpips(config);
}

// [1, 3, H, W] float32 RGB in [0, 1] of a shared pair image ("ref" or "dist").
inline torch::Tensor load_pair_image(const std::string& which, const std::string& name) {
  return handscs::hwc_to_bchw(handscs::load_rgb_image(pairs_dir() + "/" + which + "/" + name + ".bmp"));
}

// A fresh empty folder under the system temp folder.
inline std::string temp_dir(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() / ("handscs_test_metrics_" + name);
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir.string();
}

using handscs_test::error_of;

struct GradCheck {
  double max_abs_error = 0;   // max |analytic - numeric| over the checked coordinates/directions
  double max_abs_grad = 0;    // scale of the analytic gradient (or directional derivative)
  double relative() const { return max_abs_error / std::max(max_abs_grad, 1e-300); }
};

// Compares autograd's gradient of the scalar f(x) with central differences (step h) on
// `coordinates` coordinates (all when <= 0 or >= numel) and `directions` random unit directions.
inline GradCheck check_gradient(const std::function<torch::Tensor(const torch::Tensor&)>& f,
                                const torch::Tensor& x0, double h, int64_t coordinates,
                                int directions, uint64_t seed = 7) {
  auto x = x0.detach().clone().set_requires_grad(true);
  const auto grad = torch::autograd::grad({f(x)}, {x})[0].detach();
  GradCheck result;
  auto eval = [&](const torch::Tensor& point) { return f(point).item<double>(); };
  const auto base = x0.detach();
  const int64_t n = base.numel();
  std::mt19937_64 rng(seed);
  std::vector<int64_t> indices;
  if (coordinates <= 0 || coordinates >= n) {
    for (int64_t i = 0; i < n; ++i) indices.push_back(i);
  } else {
    std::uniform_int_distribution<int64_t> pick(0, n - 1);
    for (int64_t k = 0; k < coordinates; ++k) indices.push_back(pick(rng));
  }
  const auto flat_grad = grad.reshape({-1});
  for (int64_t i : indices) {
    auto plus = base.clone();
    auto minus = base.clone();
    plus.view({-1})[i] += h;
    minus.view({-1})[i] -= h;
    const double numeric = (eval(plus) - eval(minus)) / (2 * h);
    const double analytic = flat_grad[i].item<double>();
    result.max_abs_error = std::max(result.max_abs_error, std::abs(numeric - analytic));
    result.max_abs_grad = std::max(result.max_abs_grad, std::abs(analytic));
  }
  at::manual_seed(seed);
  for (int d = 0; d < directions; ++d) {
    auto dir = torch::randn(base.sizes(), base.options());
    dir /= dir.norm();
    const double numeric = (eval(base + h * dir) - eval(base - h * dir)) / (2 * h);
    const double analytic = (grad * dir).sum().item<double>();
    result.max_abs_error = std::max(result.max_abs_error, std::abs(numeric - analytic));
    result.max_abs_grad = std::max(result.max_abs_grad, std::abs(analytic));
  }
  return result;
}

// A smooth random image [B, C, H, W] in (0, 1) (blurred noise, so SSIM/LPIPS see structure).
inline torch::Tensor smooth_image(at::IntArrayRef size, uint64_t seed, torch::Dtype dtype = torch::kDouble) {
  at::manual_seed(seed);
  auto noise = torch::rand(size, torch::kDouble);
  auto kernel = torch::ones({size[1], 1, 3, 3}, torch::kDouble) / 9.0;
  auto smooth = at::conv2d(noise, kernel, {}, 1, 1, 1, size[1]);
  return (0.1 + 0.8 * smooth).to(dtype);
}

// A smooth random RGB image [h, w, 3] in float (smooth_image in HWC layout).
inline torch::Tensor random_hwc(int64_t h, int64_t w, uint64_t seed) {
  return handscs::bchw_to_hwc(smooth_image({1, 3, h, w}, seed, torch::kFloat));
}

// Writes an RGB image [h, w, 3] in [0, 1] as a PNG (the test fails when it cannot).
inline void write_png(const std::string& path, const torch::Tensor& hwc) {
  REQUIRE(cv::imwrite(path, handscs::rgb_tensor_to_mat(hwc)));
}

}  // namespace metrics_test
