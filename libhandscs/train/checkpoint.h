// Checkpoint files: JSON metadata + named tensors (torch pickle), sealed by a trailer holding a magic
// tag, the payload length and its FNV-1a 64-bit hash. Written atomically (temp file + rename); a
// truncated or corrupted file is refused on load with a message naming it.
#pragma once

#include <map>
#include <string>

#include <nlohmann/json.hpp>
#include <torch/types.h>

namespace handscs {

struct Checkpoint {
  nlohmann::json meta = nlohmann::json::object();  // iteration, config, counters, RNG text state
  std::map<std::string, torch::Tensor> tensors;      // every tensor, by name
};

void save_checkpoint(const std::string& path, const Checkpoint& checkpoint);
// Throws Error naming the path if the file is missing, truncated, corrupted or of another format.
Checkpoint load_checkpoint(const std::string& path);

}  // namespace handscs
