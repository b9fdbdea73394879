// train/out_of_memory.h: LibTorch's and the C++ allocator's failures are told from other errors and
// turned into a message naming when memory ran out, the Gaussian count and the keys to change.
#include <torch/torch.h>

#include <new>
#include <stdexcept>

#include "train/out_of_memory.h"

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
  CHECK(std::string(out_of_memory_error(failed_torch_allocation(), "at step 71", 868000).what()) ==
        "out of memory at step 71 with 868000 Gaussians (a request of 4503599.6 GB failed)" + kKeys +
            "; the last checkpoint is kept");
  CHECK(std::string(out_of_memory_error(std::bad_alloc(), "validating at step 500", 2872).what()) ==
        "out of memory validating at step 500 with 2872 Gaussians" + kKeys + "; the last checkpoint is kept");
  // Before the model exists there is no count and no checkpoint to speak of.
  CHECK(std::string(out_of_memory_error(std::bad_alloc(), "while opening the run", -1).what()) ==
        "out of memory while opening the run" + kKeys);
}
