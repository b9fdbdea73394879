// Data-parallel training across processes and machines over LibTorch's own distributed engine, c10d:
// a TCPStore rendezvous and a ProcessGroupGloo for the collectives (no home-made networking). Each
// rank renders its share of a step's views; gradients are summed across ranks (the trainer divides
// by the world size). Every collective waits at most the timeout: a rank that dies ends the others
// at once ("connection closed"), one that stops answering ends them after the timeout, and either
// way they exit with an Error naming the rank and the operation, never a hang.
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include <torch/types.h>

namespace handscs {

struct DataParallelOptions {
  int rank = 0;
  int world_size = 1;                    // 1: a single process, no rendezvous
  std::string master_addr = "127.0.0.1";  // rank 0's host (it runs the rendezvous store)
  int master_port = 29500;               // torchrun's default
  double timeout_s = 300;  // rendezvous and every collective: long enough for a first open of a
                           // release-size capture on a slow rank, short enough to notice a hang
};

// RANK, WORLD_SIZE, MASTER_ADDR and MASTER_PORT as torchrun and Slurm scripts set them; unset
// variables keep `defaults`. Throws Error naming the variable for a malformed or inconsistent value.
DataParallelOptions data_parallel_from_environment(DataParallelOptions defaults = {});
// Throws Error naming the field for a rank outside [0, world_size) or a port outside 1..65535.
void validate_data_parallel(const DataParallelOptions& options);

// What the collectives moved and how long they took (this rank's view).
struct CommunicationStats {
  int64_t calls = 0;
  int64_t bytes = 0;    // payload bytes handed to the collectives
  double seconds = 0;   // wall time inside them, waiting for the slowest rank included
};

class ProcessGroup {
 public:
  // Rendezvous with the other ranks (rank 0 serves the store on master_addr:master_port).
  explicit ProcessGroup(const DataParallelOptions& options);
  ~ProcessGroup();
  ProcessGroup(const ProcessGroup&) = delete;
  ProcessGroup& operator=(const ProcessGroup&) = delete;

  int rank() const { return options_.rank; }
  int world_size() const { return options_.world_size; }
  bool is_root() const { return options_.rank == 0; }

  // In place: every rank ends with the element-wise sum (bit-identical on every rank).
  void all_reduce_sum(torch::Tensor& tensor);  // contiguous CPU tensor
  // Every rank ends with root's bytes (any length), sent as all-reduces (see the .cpp for why).
  void broadcast_bytes(std::string& bytes, int root = 0);

  const CommunicationStats& stats() const { return stats_; }

 private:
  struct Backend;
  template <class Operation>
  void run(const char* what, int64_t bytes, Operation&& operation);
  DataParallelOptions options_;
  std::unique_ptr<Backend> backend_;
  CommunicationStats stats_;
};

}  // namespace handscs
