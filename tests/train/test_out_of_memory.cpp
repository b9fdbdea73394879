// train/out_of_memory.h: LibTorch's and the C++ allocator's failures are told from other errors and
// turned into a message naming when memory ran out, the Gaussian count and the keys to change.
#include <torch/torch.h>

#include <opencv2/core.hpp>

#include <malloc.h>
#include <omp.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <functional>
#include <new>
#include <stdexcept>

#include "core/atomic_file.h"
#include "run/checkpoint.h"
#include "run/pickle_bytes.h"
#include "synth/capture.h"
#include "synth/config.h"
#include "test_support.h"
#include "tiny_capture.h"
#include "train/out_of_memory.h"
#include "train/trainer.h"

// Catch last: LibTorch pulls in glog, whose CHECK macro would otherwise replace Catch's.
#include <catch2/catch.hpp>

using namespace handscs;

namespace {

// The error LibTorch's CPU allocator throws for a request no machine can grant: 2^50 floats (4.5
// PB) exceed the address space, so the request fails at once, whatever the memory.
c10::Error failed_torch_allocation() {
  try {
    torch::empty({int64_t{1} << 50}, torch::kFloat32);
  } catch (const c10::Error& e) {
    return e;
  }
  throw std::logic_error("a 4.5 PB tensor was allocated");
}

const std::string kKeys =
    ": the machine cannot hold this run. Fewer Gaussians (a lower train.densify.max_gaussians, a "
    "higher train.densify.grad_threshold or train.densify.interval, an earlier train.densify.stop), "
    "smaller decoders (model.decoder_hidden) or smaller images (train.resolution_scale) need less";

}  // namespace

TEST_CASE("out of memory: allocation failures are told from other errors") {
  CHECK(is_out_of_memory(std::bad_alloc()));
  CHECK(is_out_of_memory(cv::Exception(cv::Error::StsNoMem, "Failed to allocate", "f", "file", 1)));
  CHECK_FALSE(is_out_of_memory(cv::Exception(cv::Error::StsBadArg, "bad argument", "f", "file", 1)));
  CHECK(is_out_of_memory(failed_torch_allocation()));
  CHECK_FALSE(is_out_of_memory(Error("configs/x.json: train.lr: not a number")));
  CHECK_FALSE(is_out_of_memory(std::runtime_error("alloc")));
  try {
    torch::zeros({2, 3}).matmul(torch::zeros({4, 5}));  // a LibTorch error of another kind
    FAIL("mismatched shapes were multiplied");
  } catch (const c10::Error& e) {
    CHECK_FALSE(is_out_of_memory(e));
  }
}

TEST_CASE("out of memory: the message names when, the Gaussian count, the request and the keys") {
  // LibTorch names the request: its size is given in the units a user compares with the machine.
  const std::string request = std::to_string(int64_t{1} << 50 << 2);  // bytes of 2^50 floats
  REQUIRE(std::string(failed_torch_allocation().what_without_backtrace()).find(request) != std::string::npos);
  CHECK(std::string(out_of_memory_error(failed_torch_allocation(), "at step 71", 868000,
                                       "run/checkpoints/step_00000050.ckpt").what()) ==
        "out of memory at step 71 with 868000 Gaussians (a request of 4503599.6 GB failed)" + kKeys +
            "; the last checkpoint, run/checkpoints/step_00000050.ckpt, is kept");
  // Before the first checkpoint there is none to keep, and the message does not promise one.
  CHECK(std::string(out_of_memory_error(std::bad_alloc(), "validating at step 500", 2872).what()) ==
        "out of memory validating at step 500 with 2872 Gaussians" + kKeys +
            "; no checkpoint was written before it");
  // Before the model exists there is no count and no checkpoint to speak of.
  CHECK(std::string(out_of_memory_error(std::bad_alloc(), "while opening the run", -1).what()) ==
        "out of memory while opening the run" + kKeys);
}

TEST_CASE("out of memory: a checkpoint's pickle is torch::pickle_save's, byte for byte") {
  c10::Dict<std::string, at::Tensor> dict;
  dict.insert("gaussians/means", torch::arange(12, torch::kFloat32).reshape({4, 3}));
  dict.insert("step", torch::tensor({7}, torch::kInt64));
  dict.insert("strided", torch::arange(20, torch::kFloat64).reshape({4, 5}).t().contiguous());
  const c10::IValue value(dict);
  CHECK(pickle_bytes(value) == torch::pickle_save(value));
  const auto back = torch::pickle_load(pickle_bytes(value)).toGenericDict();
  CHECK(back.at("gaussians/means").toTensor().equal(dict.at("gaussians/means")));
}

namespace {

// A capture of 1024 x 1536 images in which the hand is as many pixels tall as in `tiny`: training
// renders the hand's crop, the validation the whole image. It is written by a child process, so
// this process starts no OpenMP threads before the children below fork.
const std::string& large_image_capture() {
  static const std::string dir = [] {
    const std::string path = handscs_test::fresh_dir("oom_capture");
    const pid_t child = fork();
    if (child == 0) {
      try {
        SynthConfig config = synth_preset("tiny");
        config.width = 1024;
        config.height = 1536;
        config.focal = 1265.0 * 167 / 1024;  // focal is given at 334 px and scales with the width
        config.num_cameras = 1;
        config.num_frames = 5;
        config.held_out_frames = 1;
        generate_synth_capture(config, path);
        _exit(0);
      } catch (...) {
        _exit(1);
      }
    }
    if (handscs_test::exit_code_of(child) != 0) throw std::runtime_error("the capture was not written");
    return path;
  }();
  return dir;
}

// The run of case `which` ("save": decoders of 1024 units, a checkpoint of ~45 MB; "validate").
RunConfig limited_run_config(const std::string& which, const std::string& capture) {
  RunConfig config;
  config.data.root = capture;
  config.data.held_out_poses = 1;
  config.train.iterations = 10;
  config.train.checkpoint_every = 1;
  config.train.validate_every = 0;
  config.train.densify.enabled = false;
  if (which == "save") config.model.decoder_hidden = 1024;
  return config;
}

// What a child saw when memory ran out: the free heap when its address space was capped, the
// message of what it threw, and the bytes of its step-1 checkpoint before the cap.
struct LimitedRun {
  int64_t free_heap = -1;
  std::string message;
  std::string checkpoint_before;
};

// Runs case `which` in a fresh process (this test program, its hidden case below: no threads of
// this process inherited, as a fork would). The child trains one step, saves that checkpoint, takes
// a second step, caps its address space at what it maps then (setrlimit RLIMIT_AS) and saves or
// validates. Every request its heap's free blocks cannot serve fails, as on a machine out of memory.
LimitedRun run_out_of_memory(const std::string& which, const std::string& run_dir) {
  const std::string log = run_dir + ".log";
  const int code = handscs_test::exit_code_of(handscs_test::spawn(
      "env HANDSCS_OOM_CASE=" + which + " HANDSCS_OOM_RUN=" + run_dir + " HANDSCS_OOM_CAPTURE=" +
      large_image_capture() + " " + handscs_test::kBin + "/test_train \"[.oom_child]\" > " + log + " 2>&1"));
  INFO(read_file(log));
  REQUIRE(code == 0);
  LimitedRun run;
  const std::string text = read_file(run_dir + ".result");
  const size_t first = text.find('\n'), second = text.find('\n', first + 1);
  REQUIRE(second != std::string::npos);
  run.free_heap = std::stoll(text.substr(0, first));
  run.message = text.substr(first + 1, second - first - 1);
  run.checkpoint_before = text.substr(second + 1);
  return run;
}

bool ends_with(const std::string& text, const std::string& end) {
  return text.size() >= end.size() && text.compare(text.size() - end.size(), end.size(), end) == 0;
}

// The checkpoints and temporaries the run folder holds.
std::vector<std::string> checkpoint_folder(const std::string& run_dir) {
  std::vector<std::string> names;
  for (const auto& entry : std::filesystem::directory_iterator(run_dir + "/checkpoints"))
    names.push_back(entry.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

}  // namespace

TEST_CASE("out of memory while saving a checkpoint: the message names it, the previous one stays") {
  const std::string run_dir = handscs_test::fresh_dir("oom_save");
  const LimitedRun run = run_out_of_memory("save", run_dir);
  INFO(run.message);
  const std::string kept = run_dir + "/checkpoints/step_00000001.ckpt";
  // LibTorch's own pickle_save ended the process here (std::terminate from its zip writer).
  INFO("free heap at the cap " << run.free_heap << " bytes, checkpoint " << run.checkpoint_before.size());
  REQUIRE(run.free_heap >= 0);
  const int64_t gaussians = load_checkpoint(kept).tensors.at("gaussians/means").size(0);
  CHECK(run.message.rfind("out of memory saving the checkpoint of step 2 with " +
                              std::to_string(gaussians) + " Gaussians",
                          0) == 0);
  CHECK(run.message.find(kKeys) != std::string::npos);
  CHECK(ends_with(run.message, "; the last checkpoint, " + kept + ", is kept"));
  // Nothing lost: the step-1 checkpoint holds its bytes, no step-2 file or temporary was left.
  CHECK(read_file(kept) == run.checkpoint_before);
  CHECK(load_checkpoint(kept).meta.at("iteration") == 1);
  CHECK(checkpoint_folder(run_dir) == std::vector<std::string>{"step_00000001.ckpt"});
}

TEST_CASE("out of memory while validating: the message names it, the checkpoint stays") {
  const std::string run_dir = handscs_test::fresh_dir("oom_validate");
  const LimitedRun run = run_out_of_memory("validate", run_dir);
  INFO(run.message);
  const std::string kept = run_dir + "/checkpoints/step_00000001.ckpt";
  // The validation decodes and renders the whole 1024 x 1536 image; its decode's failure was taken
  // for an undecodable image ("cannot decode image (... Insufficient memory)").
  INFO("free heap at the cap " << run.free_heap << " bytes");
  REQUIRE(run.free_heap >= 0);
  const int64_t gaussians = load_checkpoint(kept).tensors.at("gaussians/means").size(0);
  CHECK(run.message.rfind("out of memory validating at step 2 with " + std::to_string(gaussians) +
                              " Gaussians",
                          0) == 0);
  CHECK(run.message.find(kKeys) != std::string::npos);
  CHECK(ends_with(run.message, "; the last checkpoint, " + kept + ", is kept"));
  CHECK(read_file(kept) == run.checkpoint_before);
  CHECK(checkpoint_folder(run_dir) == std::vector<std::string>{"step_00000001.ckpt"});
  CHECK_FALSE(std::filesystem::exists(run_dir + "/validation/step_00000002.png"));
}

TEST_CASE("out of memory: the child of the two cases above", "[.oom_child]") {
  const char* which = std::getenv("HANDSCS_OOM_CASE");
  const char* run_dir = std::getenv("HANDSCS_OOM_RUN");
  const char* capture = std::getenv("HANDSCS_OOM_CAPTURE");
  // Selected with its file's other cases (--filenames-as-tags), it has nothing to do.
  if (which == nullptr || run_dir == nullptr || capture == nullptr) return;
  std::ofstream out(std::string(run_dir) + ".result");
  try {
    torch::set_num_threads(1);
    omp_set_num_threads(1);
    Trainer trainer(limited_run_config(which, capture), run_dir);
    trainer.step();
    const std::string kept = trainer.save_checkpoint();
    trainer.step();
    const std::string before = read_file(kept);
    long pages = 0;
    std::ifstream("/proc/self/statm") >> pages;
    const rlim_t cap = static_cast<rlim_t>(pages) * sysconf(_SC_PAGESIZE);
    // The soft limit only, lifted again after the call so that Catch can report.
    const int64_t free_heap = static_cast<int64_t>(mallinfo2().fordblks);
    rlimit limit{cap, RLIM_INFINITY};
    REQUIRE(setrlimit(RLIMIT_AS, &limit) == 0);
    std::string message = "(no error)";
    try {
      if (std::string(which) == "save")
        trainer.save_checkpoint();
      else
        trainer.validate();
    } catch (const std::exception& e) {
      message = e.what();
    }
    limit.rlim_cur = RLIM_INFINITY;
    setrlimit(RLIMIT_AS, &limit);
    out << free_heap << "\n" << message << "\n";
    out.write(before.data(), static_cast<std::streamsize>(before.size()));
  } catch (const std::exception& e) {
    out << "-1\nthe child failed before the cap: " << e.what() << "\n";
  }
}
