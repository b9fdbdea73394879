// handscs-bench-raster: times the splat rasterizer's forward and backward pass (median over repeats after warm-up)
// and counts its work. Scenes: `uniform` (N Gaussians spread over the image, depth 0.9-1.1 m, random rotations,
// projected sigma 1.5-3.5 px, opacity U(0.05, 0.95), random colours; fixed seed) and `hand` (N Gaussians sampled
// on the built-in hand's posed skin, seen from a capture-like camera 0.55 m away). Prints one JSON object with
// median forward and backward wall-clock ms, visible Gaussians, visible (tile, Gaussian) pairs and contributing
// (pixel, Gaussian) pairs. Forward = rasterize_gaussians with autograd recording; backward = its backward pass
// seeded with fixed random cotangents for rgb and alpha.
#include <algorithm>
#include <chrono>
#include <fstream>
#include <cmath>
#include <iostream>
#include <random>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <torch/types.h>
#include <torch/csrc/autograd/autograd.h>

#include "core/allocator.h"
#include "core/logging.h"
#include "core/threads.h"
#include "core/vec3.h"
#include "hand/lbs.h"
#include "hand/rig.h"
#include "render/raster_work.h"
#include "render/rasterize.h"
#include "core/simd_level.h"
#include "bench_timing.h"

namespace {

using bench::Clock;
using bench::median;
using bench::ms_since;
using bench::seconds_since;

using handscs::Camera;
using handscs::cross;
using handscs::norm;
using handscs::normalized;
using handscs::operator-;
using handscs::Vec3;

struct Scene {
  torch::Tensor means, covs, colors, opacities;
  Camera camera;
};

Camera centred_camera(int width, int height, double focal) {
  Camera cam;
  cam.width = width;
  cam.height = height;
  cam.K = {focal, 0, 0.5 * width, 0, focal, 0.5 * height, 0, 0, 1};
  return cam;
}

// Spec: centres uniform over the image at depth 0.9-1.1 m, random rotations, projected standard deviations
// 1.5-3.5 px, opacity U(0.05, 0.95), colours U(0, 1).
Scene uniform_scene(int n, int width, int height, uint64_t seed) {
  Scene s;
  s.camera = centred_camera(width, height, 600.0);
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  std::normal_distribution<double> N01(0.0, 1.0);
  auto means = torch::empty({n, 3}, torch::kFloat64), scales = torch::empty({n, 3}, torch::kFloat64);
  auto quats = torch::empty({n, 4}, torch::kFloat64), colors = torch::empty({n, 3}, torch::kFloat64);
  auto opac = torch::empty({n}, torch::kFloat64);
  auto m = means.accessor<double, 2>(), sc = scales.accessor<double, 2>(), q = quats.accessor<double, 2>();
  auto c = colors.accessor<double, 2>();
  auto o = opac.accessor<double, 1>();
  const double f = s.camera.fx(), cx = s.camera.cx(), cy = s.camera.cy();
  for (int i = 0; i < n; ++i) {
    const double z = 0.9 + 0.2 * U(rng), u = width * U(rng), v = height * U(rng);
    m[i][0] = (u - cx) / f * z;
    m[i][1] = (v - cy) / f * z;
    m[i][2] = z;
    for (int k = 0; k < 3; ++k) {
      sc[i][k] = (1.5 + 2.0 * U(rng)) * z / f;
      c[i][k] = U(rng);
    }
    for (int k = 0; k < 4; ++k) q[i][k] = N01(rng);
    o[i] = 0.05 + 0.9 * U(rng);
  }
  s.means = means.to(torch::kFloat32);
  s.covs = handscs::covariance_from_scale_rotation(scales, quats).to(torch::kFloat32);
  s.colors = colors.to(torch::kFloat32);
  s.opacities = opac.to(torch::kFloat32);
  return s;
}

// N surfels on the built-in hand (posed with the rig's mean finger pose), area-weighted over the faces,
// flattened along the face normal; camera 0.55 m from the hand looking at its back, 700 px focal length.
Scene hand_scene(int n, int width, int height, uint64_t seed) {
  const handscs::Rig rig = handscs::load_rig_source("builtin");
  const auto pose = torch::zeros({1, handscs::kPoseDim}, torch::kFloat64);
  const auto shape = torch::zeros({1, handscs::kShapeDim}, torch::kFloat64);
  const auto trans = torch::zeros({1, 3}, torch::kFloat64);
  const auto verts = handscs::lbs(rig, pose, shape, trans).vertices[0].contiguous();
  const auto faces = rig.faces.to(torch::kInt64).contiguous();
  auto V = verts.accessor<double, 2>();
  auto F = faces.accessor<int64_t, 2>();
  const int64_t num_faces = faces.size(0);
  std::vector<double> cdf(num_faces);
  double total = 0;
  auto vec = [&](int64_t vi) { return Vec3{V[vi][0], V[vi][1], V[vi][2]}; };
  for (int64_t f = 0; f < num_faces; ++f) {
    total += 0.5 * norm(cross(vec(F[f][1]) - vec(F[f][0]), vec(F[f][2]) - vec(F[f][0])));
    cdf[f] = total;
  }
  Vec3 centre{0, 0, 0};
  for (int64_t i = 0; i < verts.size(0); ++i)
    for (int k = 0; k < 3; ++k) centre[k] += V[i][k] / double(verts.size(0));

  // Look at the hand from the back (+y in the canonical frame), slightly tilted.
  Scene s;
  s.camera = centred_camera(width, height, 700.0);
  const Vec3 eye{centre[0] + 0.12, centre[1] + 0.52, centre[2] + 0.12};
  const auto zc = normalized(centre - eye);
  const auto xc = normalized(cross(zc, {1.0, 0.0, 0.0}));
  const auto yc = cross(zc, xc);
  for (int k = 0; k < 3; ++k) {
    s.camera.R[k] = xc[k];
    s.camera.R[3 + k] = yc[k];
    s.camera.R[6 + k] = zc[k];
  }
  for (int r = 0; r < 3; ++r)
    s.camera.t[r] = -(s.camera.R[3 * r] * eye[0] + s.camera.R[3 * r + 1] * eye[1] + s.camera.R[3 * r + 2] * eye[2]);

  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  const double tangent_sigma = 0.7 * std::sqrt(total / n), normal_sigma = 0.15 * tangent_sigma;
  auto means = torch::empty({n, 3}, torch::kFloat64), covs = torch::empty({n, 6}, torch::kFloat64);
  auto colors = torch::empty({n, 3}, torch::kFloat64), opac = torch::empty({n}, torch::kFloat64);
  auto m = means.accessor<double, 2>(), cv = covs.accessor<double, 2>(), c = colors.accessor<double, 2>();
  auto o = opac.accessor<double, 1>();
  for (int i = 0; i < n; ++i) {
    const int64_t f = std::min<int64_t>(std::lower_bound(cdf.begin(), cdf.end(), U(rng) * total) - cdf.begin(),
                                        num_faces - 1);
    const auto a = vec(F[f][0]), b = vec(F[f][1]), d = vec(F[f][2]);
    double r1 = std::sqrt(U(rng)), r2 = U(rng);
    for (int k = 0; k < 3; ++k) m[i][k] = (1 - r1) * a[k] + r1 * (1 - r2) * b[k] + r1 * r2 * d[k];
    const auto nrm = normalized(cross(b - a, d - a));
    // Sigma = ts^2 I + (ns^2 - ts^2) n n^T: a disc in the face plane.
    const double ts2 = tangent_sigma * tangent_sigma, ns2 = normal_sigma * normal_sigma;
    const int idx[6][2] = {{0, 0}, {0, 1}, {0, 2}, {1, 1}, {1, 2}, {2, 2}};
    for (int e = 0; e < 6; ++e) {
      const int p = idx[e][0], q = idx[e][1];
      cv[i][e] = (p == q ? ts2 : 0.0) + (ns2 - ts2) * nrm[p] * nrm[q];
    }
    const double shade = 0.9 + 0.2 * U(rng);
    c[i][0] = std::min(1.0, 0.86 * shade);
    c[i][1] = std::min(1.0, 0.66 * shade);
    c[i][2] = std::min(1.0, 0.55 * shade);
    o[i] = 0.5 + 0.49 * U(rng);
  }
  s.means = means.to(torch::kFloat32);
  s.covs = covs.to(torch::kFloat32);
  s.colors = colors.to(torch::kFloat32);
  s.opacities = opac.to(torch::kFloat32);
  return s;
}

}  // namespace

int main(int argc, char** argv) {
  handscs::log_to_stderr();  // stdout carries the JSON only
  handscs::keep_freed_memory_for_reuse();  // as the tools run (core/allocator.h)
  CLI::App app{"handscs-bench-raster: rasterizer forward/backward timing"};
  int gaussians = 10000, width = 512, height = 334, threads = 2, repeats = 20, warmup = 3;
  uint64_t seed = 1;
  std::string scene_name = "uniform", simd = "auto";
  bool json_only = false;
  std::string image_path;
  app.add_option("--gaussians", gaussians, "number of Gaussians")->check(CLI::Range(0, 100000000));
  app.add_option("--width", width, "image width")->check(CLI::Range(1, 16384));
  app.add_option("--height", height, "image height")->check(CLI::Range(1, 16384));
  app.add_option("--threads", threads, "threads (0 = all cores)")->check(CLI::Range(0, 1024));
  app.add_option("--repeats", repeats, "timed repeats")->check(CLI::Range(1, 100000));
  app.add_option("--warmup", warmup, "untimed warm-up runs")->check(CLI::Range(0, 1000));
  app.add_option("--scene", scene_name, "uniform or hand")->check(CLI::IsMember({"uniform", "hand"}));
  app.add_option("--seed", seed, "scene seed");
  app.add_option("--simd", simd, "auto, generic, avx2 or avx512 (capped by the CPU)")
      ->check(CLI::IsMember({"auto", "generic", "avx2", "avx512"}));
  app.add_flag("--json", json_only, "print only the JSON object");
  app.add_option("--image", image_path, "also write the rendered image as a binary PPM (to look at the scene)");
  CLI11_PARSE(app, argc, argv);
  try {
    const int used_threads = handscs::set_threads(threads);
    if (simd == "generic") handscs::set_simd_level(handscs::SimdLevel::generic);
    if (simd == "avx2") handscs::set_simd_level(handscs::SimdLevel::avx2);
    if (simd == "avx512") handscs::set_simd_level(handscs::SimdLevel::avx512);
    const Scene s = scene_name == "hand" ? hand_scene(gaussians, width, height, seed)
                                         : uniform_scene(gaussians, width, height, seed);
    handscs::RasterSettings settings;
    const handscs::RasterWork work =
        handscs::measure_raster_work(s.means, s.covs, s.colors, s.opacities, s.camera, settings);

    auto means = s.means.clone().requires_grad_(true), covs = s.covs.clone().requires_grad_(true);
    auto colors = s.colors.clone().requires_grad_(true), opac = s.opacities.clone().requires_grad_(true);
    const auto v_rgb = torch::rand({height, width, 3}) - 0.5, v_alpha = torch::rand({height, width}) - 0.5;
    std::vector<double> fwd_ms, bwd_ms;
    using clock = std::chrono::steady_clock;
    for (int it = 0; it < warmup + repeats; ++it) {
      for (auto* t : {&means, &covs, &colors, &opac}) t->mutable_grad() = torch::Tensor();
      const auto t0 = clock::now();
      const handscs::RasterOutput out = handscs::rasterize_gaussians(means, covs, colors, opac, s.camera, settings);
      const auto t1 = clock::now();
      torch::autograd::backward({out.rgb, out.alpha}, {v_rgb, v_alpha});
      const auto t2 = clock::now();
      if (it >= warmup) {
        fwd_ms.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
        bwd_ms.push_back(std::chrono::duration<double, std::milli>(t2 - t1).count());
      }
    }
    if (!image_path.empty()) {
      c10::InferenceMode guard;
      const auto rgb = handscs::rasterize_gaussians(s.means, s.covs, s.colors, s.opacities, s.camera, settings).rgb;
      const auto bytes = (rgb.clamp(0, 1) * 255).round().to(torch::kUInt8).contiguous();
      std::ofstream out(image_path, std::ios::binary);
      out << "P6\n" << width << " " << height << "\n255\n";
      out.write(reinterpret_cast<const char*>(bytes.data_ptr<uint8_t>()), bytes.numel());
      if (!out) throw std::runtime_error(image_path + ": cannot write");
    }
    std::vector<double> total_ms(fwd_ms.size());
    for (size_t i = 0; i < fwd_ms.size(); ++i) total_ms[i] = fwd_ms[i] + bwd_ms[i];
    nlohmann::json j;
    j["bench"] = "raster";
    j["scene"] = scene_name;
    j["gaussians"] = gaussians;
    j["width"] = width;
    j["height"] = height;
    j["threads"] = used_threads;
    j["simd"] = handscs::simd_level_name(handscs::active_simd_level());
    j["dtype"] = "float32";
    j["warmup"] = warmup;
    j["repeats"] = repeats;
    j["forward_ms_median"] = median(fwd_ms);
    j["backward_ms_median"] = median(bwd_ms);
    j["total_ms_median"] = median(total_ms);
    j["total_ms_min"] = *std::min_element(total_ms.begin(), total_ms.end());
    j["visible_gaussians"] = work.visible_gaussians;
    j["visible_pairs"] = work.tile_entries;  // (tile, Gaussian) pairs after culling and binning
    {
      // The machine is shared: record how busy it was, since timings on a loaded machine are inflated.
      std::ifstream load("/proc/loadavg");
      double one_minute = -1;
      if (load >> one_minute) j["load_average_1min"] = one_minute;
    }
    j["contributing_pairs"] = work.contributing_pairs;
    if (!json_only)
      std::cerr << "forward " << median(fwd_ms) << " ms, backward " << median(bwd_ms) << " ms (median of " << repeats
                << ")\n";
    std::cout << j.dump() << std::endl;
  } catch (const std::exception& e) {
    std::cerr << "handscs-bench-raster: " << e.what() << std::endl;
    return 1;
  }
  return 0;
}
