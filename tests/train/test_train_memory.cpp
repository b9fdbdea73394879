// train/train_memory.h: the Gaussian count densification can reach, the crops read from the
// capture, the estimate against a run's measured peak, and the refusal naming the keys.
#include <torch/torch.h>

#include <sys/resource.h>
#include <sys/wait.h>

#include <algorithm>
#include <fstream>
#include <regex>
#include <string>

#include "core/atomic_file.h"
#include "data/capture.h"
#include "test_support.h"
#include "tiny_capture.h"
#include "train/train_memory.h"

// Catch last: LibTorch pulls in glog, whose CHECK macro would otherwise replace Catch's.
#include <catch2/catch.hpp>

using namespace handscs;

TEST_CASE("train memory: densification at most doubles the count a round, up to its cap") {
  TrainConfig train;
  train.iterations = 3000;
  train.densify.start = 100;
  train.densify.interval = 100;
  train.densify.stop = 250;  // rounds at steps 100 and 200
  train.densify.max_gaussians = 1000000;
  CHECK(reachable_gaussians(train, 1000) == 4000);
  train.densify.max_gaussians = 3000;
  CHECK(reachable_gaussians(train, 1000) == 3000);
  train.iterations = 150;  // the run ends before the second round
  train.densify.max_gaussians = 1000000;
  CHECK(reachable_gaussians(train, 1000) == 2000);
  train.iterations = 99;  // before the first
  CHECK(reachable_gaussians(train, 1000) == 1000);
  train.iterations = 3000;
  train.densify.enabled = false;
  CHECK(reachable_gaussians(train, 1000) == 1000);
  // A count above the cap (a checkpoint of an earlier, larger cap) is what the run holds.
  train.densify.enabled = true;
  train.densify.max_gaussians = 500;
  CHECK(reachable_gaussians(train, 1000) == 1000);
}

TEST_CASE("train memory: the crops estimated from the posed mesh are the crops training loads") {
  RunConfig config = handscs_test::tiny_run_config();
  Capture capture = Capture::open(config.data);
  const TrainMemoryInputs in = train_memory_inputs(capture, 1000, 1);
  int64_t total = 0, largest = 0;
  for (const FrameInfo& frame : capture.train()) {
    const FrameSample sample = capture.load(frame);
    const int64_t pixels = int64_t{sample.roi.width()} * sample.roi.height();
    total += pixels;
    largest = std::max(largest, pixels);
  }
  INFO(in.crop_pixels << " against " << total << ", largest " << in.largest_crop << " against " << largest);
  // The loaded crop is the refined mask's box, the estimate the mesh's: within 20%.
  CHECK(std::abs(in.crop_pixels - total) < total / 5);
  CHECK(std::abs(in.largest_crop - largest) < largest / 5);
  CHECK(in.largest_image == 167 * 256);
}

TEST_CASE("train memory: a run this machine cannot hold is refused naming both figures and the keys") {
  TrainMemoryEstimate e;
  e.process = 210'000'000;
  e.gaussians = 3'000'000'000;
  e.gaussian_count = 175'000;
  e.images = 40'000'000;
  e.pixels = 50'000'000;
  CHECK(handscs_test::error_of([&] { check_train_memory(e, 2'000'000'000); }) ==
        "train: this run needs about 3.3 GB at the peak (175000 Gaussians: 3.0 GB, cached images: 40 "
        "MB, rendered pixels: 50 MB, the process: 210 MB), more than the 2.0 GB this machine has "
        "available. Fewer Gaussians (train.densify.max_gaussians), smaller decoders "
        "(model.decoder_hidden), a smaller image cache (data.cache.budget_mb) or smaller images "
        "(train.resolution_scale, train.views_per_pose) need less");
  CHECK(handscs_test::error_of([&] { check_train_memory(e, 4'000'000'000); }) == "(no error)");
  CHECK(handscs_test::error_of([&] { check_train_memory(e, -1); }) == "(no error)");  // not known
}

TEST_CASE("train memory: the estimate printed at start is within 25% of the run's measured peak") {
  // handscs-train on the tiny capture, densifying to 6,000 Gaussians; the peak resident memory
  // comes from the kernel (wait4's ru_maxrss), the estimate from the run's log.
  const std::string run_dir = handscs_test::fresh_dir("memory_estimate");
  const std::string log = run_dir + ".log";
  const pid_t pid = handscs_test::spawn(
      handscs_test::kBin + "/handscs-train --threads 1 --config " + handscs_test::kSource +
      "/configs/tiny.json --out " + run_dir + " --set data.root=" + handscs_test::tiny_capture_dir() +
      " train.iterations=40 train.densify.start=1 train.densify.interval=5 "
      "train.densify.grad_threshold=0 train.densify.max_gaussians=6000 > " + log + " 2>&1");
  int status = 0;
  rusage usage{};
  REQUIRE(wait4(pid, &status, 0, &usage) == pid);
  const std::string text = read_file(log);
  INFO(text);
  REQUIRE(WIFEXITED(status));
  REQUIRE(WEXITSTATUS(status) == 0);
  std::smatch match;
  REQUIRE(std::regex_search(text, match, std::regex("memory: about ([0-9]+) MB at the peak \\(6000 Gaussians")));
  const double estimate_mb = std::stod(match[1]);
  const double measured_mb = usage.ru_maxrss * 1024.0 / 1e6;  // ru_maxrss is in KiB
  INFO("estimate " << estimate_mb << " MB, measured " << measured_mb << " MB");
  CHECK(estimate_mb > 0.75 * measured_mb);
  CHECK(estimate_mb < 1.25 * measured_mb);
}

TEST_CASE("train memory: handscs-train refuses a run beyond the machine's memory before writing") {
  // Densification every step without a cap would reach 100 million Gaussians: refused at start,
  // naming the estimate and the keys, the folder left without a run.
  const std::string run_dir = handscs_test::fresh_dir("memory_refused");
  const std::string log = run_dir + ".log";
  const int code = handscs_test::exit_code_of(handscs_test::spawn(
      handscs_test::kBin + "/handscs-train --threads 1 --config " + handscs_test::kSource +
      "/configs/tiny.json --out " + run_dir + " --set data.root=" + handscs_test::tiny_capture_dir() +
      " train.iterations=200 train.densify.start=1 train.densify.interval=1"
      " train.densify.grad_threshold=0 train.densify.max_gaussians=100000000 > " + log + " 2>&1"));
  const std::string text = read_file(log);
  INFO(text);
  CHECK(code == 1);
  CHECK(text.find("train: this run needs about ") != std::string::npos);
  CHECK(text.find("(100000000 Gaussians: ") != std::string::npos);
  CHECK(text.find("this machine has available. Fewer Gaussians (train.densify.max_gaussians)") !=
        std::string::npos);
  CHECK_FALSE(std::filesystem::exists(run_dir + "/config.json"));
  CHECK_FALSE(std::filesystem::exists(run_dir + "/checkpoints"));
  CHECK_FALSE(std::filesystem::exists(run_dir + "/metrics.csv"));
}
