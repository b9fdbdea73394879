// handscs-bench-data: reading speed and memory of a capture (default: the synthetic `bench`
// preset, generated on first use). Prints one JSON object: open time; the capture identity's cost
// per frame (data/capture_identity.h: every training, resume and evaluation computes it); JPEG
// decode rate (1 thread and --threads); mask rate (posed-mesh rasterisation + refinement); two
// passes over the training frames in shuffled order through Capture::load with prefetching (rate
// per pass, cache statistics); and the peak resident memory (VmHWM) of the process, read right
// after the two passes.
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <numeric>
#include <opencv2/core.hpp>
#include <random>

#include "core/cli.h"
#include "core/logging.h"
#include "data/capture.h"
#include "data/capture_identity.h"
#include "synth/capture.h"
#include "bench_timing.h"

namespace {

using bench::Clock;
using bench::median;
using bench::ms_since;
using bench::seconds_since;

// A field of /proc/self/status in MiB ("VmHWM", "VmRSS").
double status_mb(const std::string& field) {
  std::ifstream in("/proc/self/status");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind(field + ":", 0) == 0) return std::stod(line.substr(field.size() + 1)) / 1024.0;
  return -1;
}

}  // namespace

int main(int argc, char** argv) {
  handscs::log_to_stderr();  // stdout carries the JSON only
  CLI::App app{"handscs-bench-data: capture reading speed and memory"};
  handscs::CommonOptions common;
  handscs::add_common_options(app, common, false);
  std::string root = (std::filesystem::temp_directory_path() / "handscs_bench_capture").string();
  int repeats = 3, decode_images = 600, mask_images = 300, prefetch_ahead = 8, prefetch_threads = 1;
  int64_t budget_mb = 1024;
  app.add_option("--root", root, "capture folder (the bench preset is generated there if missing)")
      ->capture_default_str();
  app.add_option("--repeats", repeats, "repeats of the decode and mask timings (median)")
      ->capture_default_str();
  app.add_option("--decode-images", decode_images, "images per decode timing")
      ->capture_default_str();
  app.add_option("--mask-images", mask_images, "images per mask timing")->capture_default_str();
  app.add_option("--budget-mb", budget_mb, "crop cache budget (MiB)")->capture_default_str();
  app.add_option("--prefetch-threads", prefetch_threads, "background loader threads")
      ->capture_default_str();
  app.add_option("--prefetch-ahead", prefetch_ahead, "frames queued ahead of the one loaded")
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  try {
    handscs::start_up(common, "handscs-bench-data");
    nlohmann::json out;
    out["bench"] = "data";
    out["note"] = "2-core machine shared with other jobs: timings are noisy";
    if (!std::filesystem::exists(std::filesystem::path(root) / "annotations")) {
      const auto start = Clock::now();
      handscs::generate_synth_capture(handscs::synth_preset("bench"), root);
      out["generate_bench_s"] = seconds_since(start);
    }
    handscs::CaptureConfig config;
    config.root = root;
    config.cache.budget_mb = budget_mb;
    config.cache.prefetch_threads = prefetch_threads;
    const std::string mask_dir = (std::filesystem::temp_directory_path() /
                                  ("handscs_bench_masks_" + std::to_string(::getpid())))
                                     .string();
    std::filesystem::remove_all(mask_dir);
    // An untimed open (the process's one-off start costs; the annotation cache warmed), then opens
    // without the image-check cache (every image checked), with a fresh one (checked and stored),
    // and again (every result read from it).
    const std::string scan_dir = (std::filesystem::temp_directory_path() /
                                  ("handscs_bench_scans_" + std::to_string(::getpid())))
                                     .string();
    std::filesystem::remove_all(scan_dir);
    const double rss_start = status_mb("VmRSS");
    config.scan_cache = "off";
    (void)handscs::Capture::open(config, mask_dir);
    auto start = Clock::now();
    (void)handscs::Capture::open(config, mask_dir);
    out["open_no_scan_cache_s"] = seconds_since(start);
    config.scan_cache = scan_dir;
    start = Clock::now();
    (void)handscs::Capture::open(config, mask_dir);
    out["open_scan_cache_first_s"] = seconds_since(start);
    start = Clock::now();
    handscs::Capture capture = handscs::Capture::open(config, mask_dir);
    out["open_scan_cache_later_s"] = seconds_since(start);
    std::filesystem::remove_all(scan_dir);
    out["images"] = capture.frames().size();
    out["train_images"] = capture.train().size();
    out["rss_before_open_mb"] = rss_start;
    out["rss_after_open_mb"] = status_mb("VmRSS");

    // The identity is a sum over frames of two hashes each, so its time per frame gives its time on
    // a capture of any size.
    handscs::CaptureIdentity identity;
    const bench::Timing identity_time =
        bench::time_repeated([&] { identity = handscs::capture_identity(capture, capture.frames()); }, 1,
                             std::max(repeats, 5));
    out["identity"] = {{"frames", identity.frames},
                       {"median_ms", identity_time.median_ms},
                       {"us_per_frame", 1000.0 * identity_time.median_ms / std::max<int64_t>(1, identity.frames)}};

    // Two passes over the training frames in shuffled order, as a training loop would read them.
    std::vector<int64_t> order;
    for (const auto& f : capture.train()) order.push_back(f.index);
    std::mt19937 rng(7);
    nlohmann::json passes = nlohmann::json::array();
    size_t max_cache = 0;
    int64_t crop_pixels = 0;
    for (int pass = 0; pass < 2; ++pass) {
      std::shuffle(order.begin(), order.end(), rng);
      start = Clock::now();
      for (size_t i = 0; i < order.size(); ++i) {
        std::vector<int64_t> ahead(order.begin() + std::min(order.size(), i + 1),
                                   order.begin() + std::min(order.size(), i + 1 + prefetch_ahead));
        capture.prefetch(ahead);
        const handscs::FrameSample sample = capture.load(capture.frames()[order[i]]);
        crop_pixels += sample.mask.numel();
        max_cache = std::max(max_cache, capture.cache().bytes());
      }
      const double elapsed = seconds_since(start);
      passes.push_back({{"seconds", elapsed}, {"samples_per_s", order.size() / elapsed}});
    }
    const auto stats = capture.cache().stats();
    out["iterate"] = {{"passes", passes},
                      {"prefetch_threads", prefetch_threads},
                      {"prefetch_ahead", prefetch_ahead},
                      {"cache_budget_mb", budget_mb},
                      {"cache_max_mb", max_cache / 1048576.0},
                      {"cache_hits", stats.hits},
                      {"cache_misses", stats.misses},
                      {"cache_evictions", stats.evictions},
                      {"mean_crop_pixels", double(crop_pixels) / (2.0 * order.size())}};
    out["vmhwm_mb_after_two_passes"] = status_mb("VmHWM");
    out["rss_after_two_passes_mb"] = status_mb("VmRSS");

    // JPEG decode rate over a fixed subset (every k-th frame), 1 thread and all threads.
    const auto& frames = capture.frames();
    std::vector<int64_t> subset;
    const size_t step = std::max<size_t>(1, frames.size() / std::max(1, decode_images));
    for (size_t i = 0; i < frames.size() && subset.size() < size_t(decode_images); i += step)
      subset.push_back(i);
    for (int warm = 0; warm < 20; ++warm)
      capture.decode_image(frames[subset[warm % subset.size()]]);
    std::vector<double> single, multi;
    for (int r = 0; r < repeats; ++r) {
      start = Clock::now();
      for (int64_t i : subset) capture.decode_image(frames[i]);
      single.push_back(subset.size() / seconds_since(start));
      start = Clock::now();
      const int64_t count = static_cast<int64_t>(subset.size());
#pragma omp parallel for schedule(dynamic, 4)
      for (int64_t k = 0; k < count; ++k) {
        try {
          capture.decode_image(frames[subset[k]]);
        } catch (...) {
        }
      }
      multi.push_back(subset.size() / seconds_since(start));
    }
    out["decode"] = {{"images", subset.size()},
                     {"repeats", repeats},
                     {"images_per_s_1_thread", median(single)},
                     {"images_per_s_all_threads", median(multi)},
                     {"width", frames[0].camera.width},
                     {"height", frames[0].camera.height}};

    // Mask rate: rasterise the posed mesh into the view and refine against the (decoded) image.
    std::vector<cv::Mat> decoded;
    std::vector<int64_t> mask_subset(subset.begin(),
                                     subset.begin() + std::min<size_t>(subset.size(), mask_images));
    for (int64_t i : mask_subset) decoded.push_back(capture.decode_image(frames[i]));
    std::vector<double> mask_rates;
    int64_t mask_pixels = 0;
    for (int r = 0; r < repeats; ++r) {
      start = Clock::now();
      for (size_t k = 0; k < mask_subset.size(); ++k)
        mask_pixels += cv::countNonZero(capture.compute_mask(frames[mask_subset[k]], decoded[k]));
      mask_rates.push_back(mask_subset.size() / seconds_since(start));
    }
    out["masks"] = {{"images", mask_subset.size()},
                    {"repeats", repeats},
                    {"masks_per_s_1_thread", median(mask_rates)},
                    {"mean_hand_pixels", double(mask_pixels) / (repeats * mask_subset.size())}};
    std::filesystem::remove_all(mask_dir);
    std::cout << out.dump() << std::endl;
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
  return 0;
}
