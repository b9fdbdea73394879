// Checkpoint files: JSON metadata + named tensors (torch pickle), sealed by a trailer holding a magic
// tag, the payload length and its FNV-1a 64-bit hash. Written atomically (temp file + rename); a
// truncated or corrupted file is refused on load with a message naming it.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <torch/types.h>

namespace handscs {

struct Checkpoint {
  nlohmann::json meta = nlohmann::json::object();  // iteration, config, counters, RNG text state
  std::map<std::string, torch::Tensor> tensors;      // every tensor, by name
};

// A checkpoint holds each Gaussian's parameters and their optimiser moments (~1 kB): 64 GB is some
// 60 million Gaussians, far beyond any hand avatar; a larger file is refused before it is read.
constexpr std::uintmax_t kMaxCheckpointBytes = std::uintmax_t{64} << 30;

// data.hand both: the second hand's state is a section of the checkpoint, its tensors named
// "<section>/<name>" and its metadata under meta[section]. add_section() moves `part` in;
// checkpoint_section() takes it out, with the checkpoint's iteration and config beside the
// section's own metadata (an absent section gives no tensors and no metadata of its own).
void add_section(Checkpoint& checkpoint, const std::string& section, Checkpoint part);
Checkpoint checkpoint_section(const Checkpoint& checkpoint, const std::string& section);

void save_checkpoint(const std::string& path, const Checkpoint& checkpoint);
// Throws Error naming the path if the file is missing, truncated, corrupted or of another format.
Checkpoint load_checkpoint(const std::string& path);
// The file's bytes, and back (data-parallel ranks receive rank 0's state this way); `source` names
// the bytes in errors.
std::string checkpoint_bytes(const Checkpoint& checkpoint);
Checkpoint checkpoint_from_bytes(const std::string& bytes, const std::string& source);

// A run folder keeps its checkpoints as <run_dir>/checkpoints/step_<8-digit step>.ckpt.
std::string checkpoint_name(int64_t iteration);
// The run folder's checkpoint files, newest first (none: empty).
std::vector<std::string> list_checkpoints(const std::string& run_dir);
// The newest of them, "" when there is none.
std::string latest_checkpoint(const std::string& run_dir);

// Resolves a checkpoint argument: a file as is, a run folder to its latest checkpoint.
std::string resolve_checkpoint_path(const std::string& path);

struct OpenedCheckpoint {
  std::string path;  // the file used
  Checkpoint checkpoint;
};
// resolve_checkpoint_path + load_checkpoint, logging the file used and its step (a run folder's
// newest checkpoint is not always the one a user expects).
OpenedCheckpoint open_checkpoint(const std::string& path);

}  // namespace handscs
