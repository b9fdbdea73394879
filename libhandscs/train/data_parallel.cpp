#include "train/data_parallel.h"

// ProcessGroupGloo.hpp declares its class only under USE_C10D_GLOO (Debian's libtorch is built with
// Gloo; the headers come with libgloo-dev): libhandscs/CMakeLists.txt defines it for this file alone.

#include <chrono>
#include <csignal>
#include <cstring>
#include <cstdlib>
#include <vector>

#include <torch/csrc/distributed/c10d/ProcessGroupGloo.hpp>
#include <torch/csrc/distributed/c10d/TCPStore.hpp>
#include <torch/types.h>

#include "core/error.h"

namespace handscs {

namespace {

using Clock = std::chrono::steady_clock;

// The message without LibTorch's C++ backtrace (c10::Error appends one to what()).
std::string short_message(const std::exception& e) {
  if (const auto* c10_error = dynamic_cast<const c10::Error*>(&e))
    return c10_error->what_without_backtrace();
  return e.what();
}

int integer_variable(const char* name, int fallback) {
  const char* text = std::getenv(name);
  if (!text || !*text) return fallback;
  char* end = nullptr;
  const long value = std::strtol(text, &end, 10);
  require(*end == '\0' && value >= 0 && value <= 1000000,
          std::string("environment variable ") + name + "=" + text +
              ": expected a non-negative integer");
  return static_cast<int>(value);
}

bool is_loopback(const std::string& host) {
  return host == "localhost" || host.rfind("127.", 0) == 0 || host == "::1";
}

std::chrono::milliseconds milliseconds(double seconds) {
  return std::chrono::milliseconds(static_cast<int64_t>(seconds * 1000.0));
}

}  // namespace

DataParallelOptions data_parallel_from_environment(DataParallelOptions options) {
  options.rank = integer_variable("RANK", options.rank);
  options.world_size = integer_variable("WORLD_SIZE", options.world_size);
  options.master_port = integer_variable("MASTER_PORT", options.master_port);
  if (const char* addr = std::getenv("MASTER_ADDR"); addr && *addr) options.master_addr = addr;
  return options;
}

void validate_data_parallel(const DataParallelOptions& options) {
  require(options.world_size >= 1, "data parallel: world size must be at least 1 (WORLD_SIZE, --world-size)");
  require(options.rank >= 0 && options.rank < options.world_size,
          "data parallel: rank " + std::to_string(options.rank) + " is outside 0.." +
              std::to_string(options.world_size - 1) + " (RANK, --rank; WORLD_SIZE, --world-size)");
  require(options.master_port >= 1 && options.master_port <= 65535,
          "data parallel: port " + std::to_string(options.master_port) +
              " is outside 1..65535 (MASTER_PORT, --master-port)");
  require(!options.master_addr.empty(), "data parallel: the master address is empty (MASTER_ADDR, --master-addr)");
  require(options.timeout_s > 0, "data parallel: the timeout must be positive (--dist-timeout)");
}

struct ProcessGroup::Backend {
  c10::intrusive_ptr<c10d::Store> store;
  c10::intrusive_ptr<c10d::ProcessGroupGloo> group;
};

ProcessGroup::ProcessGroup(const DataParallelOptions& options)
    : options_(options), backend_(std::make_unique<Backend>()) {
  validate_data_parallel(options_);
  // A write to a peer that has died raises SIGPIPE, whose default action ends this process with
  // status 141 and no message (seen when a killed rank's peer sent to it). Ignored, the write fails
  // with EPIPE instead and the exchange reports the dead rank as an Error (ProcessGroup::run).
  std::signal(SIGPIPE, SIG_IGN);
  const std::string where = options_.master_addr + ":" + std::to_string(options_.master_port);
  const std::string who =
      "rank " + std::to_string(options_.rank) + " of " + std::to_string(options_.world_size);
  try {
    c10d::TCPStoreOptions store_options;
    store_options.port = static_cast<std::uint16_t>(options_.master_port);
    store_options.isServer = options_.rank == 0;
    store_options.numWorkers = options_.world_size;
    store_options.waitWorkers = true;
    store_options.timeout = milliseconds(options_.timeout_s);
    backend_->store = c10::make_intrusive<c10d::TCPStore>(options_.master_addr, store_options);
    auto gloo_options = c10d::ProcessGroupGloo::Options::create(milliseconds(options_.timeout_s));
    // On one machine the loopback device; across machines the interface the host name resolves to.
    gloo_options->devices.push_back(
        is_loopback(options_.master_addr)
            ? c10d::ProcessGroupGloo::createDeviceForHostname("127.0.0.1")
            : c10d::ProcessGroupGloo::createDefaultDevice());
    backend_->group = c10::make_intrusive<c10d::ProcessGroupGloo>(
        backend_->store, options_.rank, options_.world_size, gloo_options);
  } catch (const std::exception& e) {
    throw Error("data parallel, " + who + ": no rendezvous with the other ranks at " + where +
                " within " + std::to_string(static_cast<int>(options_.timeout_s)) +
                " s (are all ranks started with the same MASTER_ADDR, MASTER_PORT and WORLD_SIZE, "
                "and is the port free on rank 0?): " + short_message(e));
  }
}

ProcessGroup::~ProcessGroup() = default;

template <class Operation>
void ProcessGroup::run(const char* what, int64_t bytes, Operation&& operation) {
  const auto start = Clock::now();
  try {
    auto work = operation();
    work->wait(milliseconds(options_.timeout_s));
  } catch (const std::exception& e) {
    throw Error("data parallel, rank " + std::to_string(options_.rank) + " of " +
                std::to_string(options_.world_size) + ": " + what +
                " failed: another rank died, lost its connection or did not answer within " +
                std::to_string(static_cast<int>(options_.timeout_s)) + " s (" + short_message(e) + ")");
  }
  stats_.calls += 1;
  stats_.bytes += bytes;
  stats_.seconds += std::chrono::duration<double>(Clock::now() - start).count();
}

void ProcessGroup::all_reduce_sum(torch::Tensor& tensor) {
  std::vector<torch::Tensor> tensors{tensor};
  run("all-reduce", tensor.numel() * static_cast<int64_t>(tensor.element_size()),
      [&] { return backend_->group->allreduce(tensors); });
}

void ProcessGroup::broadcast_bytes(std::string& bytes, int root) {
  // Length and bytes travel as all-reduces (the root's values, zeros elsewhere; a sum of one
  // non-zero term is exact), not broadcasts: every rank then hears from every other, so a peer that
  // died is seen at once as a closed connection. A broadcast's root only sends, and Gloo let it wait
  // out the whole timeout when the receiver had died (tests/train/test_data_parallel.cpp;
  // docs/NOTES.md#data-parallel-training). It costs twice a broadcast's traffic, on
  // the rare exchanges that use it (the state at the start, after densification and rollback).
  const bool mine = options_.rank == root;
  auto length = torch::tensor({mine ? static_cast<int64_t>(bytes.size()) : 0}, torch::kInt64);
  all_reduce_sum(length);
  auto buffer = torch::zeros({length.item<int64_t>()}, torch::kUInt8);
  if (mine) std::memcpy(buffer.data_ptr(), bytes.data(), bytes.size());
  all_reduce_sum(buffer);
  bytes.assign(static_cast<const char*>(buffer.data_ptr()), buffer.numel());
}

}  // namespace handscs
