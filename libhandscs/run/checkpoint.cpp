#include "run/checkpoint.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <filesystem>

#include <ATen/core/Dict.h>
#include <torch/serialize.h>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/hash.h"
#include "run/pickle_bytes.h"

namespace handscs {

namespace {
constexpr char kMagic[8] = {'H', 'S', 'C', 'S', 'C', 'K', 'P', '1'};
constexpr size_t kTrailer = 24;  // magic (8) + payload length (8) + FNV-1a hash (8)

void put_u64(std::string& out, uint64_t value) {
  char bytes[8];
  std::memcpy(bytes, &value, 8);
  out.append(bytes, 8);
}

uint64_t get_u64(const std::string& in, size_t offset) {
  uint64_t value;
  std::memcpy(&value, in.data() + offset, 8);
  return value;
}
}  // namespace

std::string checkpoint_bytes(const Checkpoint& checkpoint) {
  c10::Dict<std::string, at::Tensor> dict;
  for (const auto& [name, tensor] : checkpoint.tensors)
    dict.insert(name, tensor.detach().contiguous());
  const std::vector<char> pickled = pickle_bytes(c10::IValue(dict));  // torch::pickle_save's bytes
  const std::string meta = checkpoint.meta.dump();
  std::string bytes;
  bytes.reserve(16 + meta.size() + pickled.size() + kTrailer);
  put_u64(bytes, meta.size());
  bytes += meta;
  bytes.append(pickled.data(), pickled.size());
  const uint64_t payload = bytes.size();
  const uint64_t hash = fnv1a64(bytes.data(), bytes.size());
  bytes.append(kMagic, 8);
  put_u64(bytes, payload);
  put_u64(bytes, hash);
  return bytes;
}

void add_section(Checkpoint& checkpoint, const std::string& section, Checkpoint part) {
  for (auto& [name, tensor] : part.tensors) checkpoint.tensors[section + "/" + name] = std::move(tensor);
  checkpoint.meta[section] = std::move(part.meta);
}

Checkpoint checkpoint_section(const Checkpoint& checkpoint, const std::string& section) {
  Checkpoint part;
  const std::string prefix = section + "/";
  for (const auto& [name, tensor] : checkpoint.tensors)
    if (name.compare(0, prefix.size(), prefix) == 0) part.tensors[name.substr(prefix.size())] = tensor;
  if (checkpoint.meta.contains(section) && checkpoint.meta[section].is_object()) part.meta = checkpoint.meta[section];
  for (const char* key : {"iteration", "config"})
    if (checkpoint.meta.contains(key)) part.meta[key] = checkpoint.meta[key];
  return part;
}

void save_checkpoint(const std::string& path, const Checkpoint& checkpoint) {
  write_file_atomic(path, checkpoint_bytes(checkpoint));
}

Checkpoint load_checkpoint(const std::string& path) {
  return checkpoint_from_bytes(read_file(path, kMaxCheckpointBytes), path);
}

Checkpoint checkpoint_from_bytes(const std::string& bytes, const std::string& path) {
  if (bytes.size() < kTrailer + 8 ||
      std::memcmp(bytes.data() + bytes.size() - kTrailer, kMagic, 8) != 0)
    throw Error(path + ": not a complete HandSCS checkpoint (truncated or another format)");
  const uint64_t payload = get_u64(bytes, bytes.size() - 16);
  const uint64_t hash = get_u64(bytes, bytes.size() - 8);
  if (payload != bytes.size() - kTrailer)
    throw Error(path + ": checkpoint length does not match its trailer (truncated or appended to)");
  if (fnv1a64(bytes.data(), payload) != hash)
    throw Error(path + ": checkpoint is corrupted (checksum mismatch)");
  const uint64_t meta_size = get_u64(bytes, 0);
  if (meta_size > payload - 8) throw Error(path + ": checkpoint metadata length is invalid");
  Checkpoint checkpoint;
  try {
    checkpoint.meta = nlohmann::json::parse(bytes.substr(8, meta_size));
    const std::vector<char> pickled(bytes.begin() + 8 + meta_size, bytes.begin() + payload);
    const auto value = torch::pickle_load(pickled);
    for (const auto& item : value.toGenericDict())
      checkpoint.tensors[item.key().toStringRef()] = item.value().toTensor();
  } catch (const std::exception& e) {
    throw Error(path + ": checkpoint payload unreadable (" + std::string(e.what()) + ")");
  }
  // Training never saves a non-finite value (such steps are skipped), so one here means a
  // diverged state or an altered file: refused like a damaged file (resume tries older ones).
  for (const auto& [name, tensor] : checkpoint.tensors)
    if (tensor.is_floating_point() && !torch::isfinite(tensor).all().item<bool>())
      throw Error(path + ": tensor '" + name +
                  "' holds NaN or Inf values (a diverged run or an altered file); use an earlier "
                  "checkpoint of the run");
  return checkpoint;
}

std::string checkpoint_name(int64_t iteration) {
  char name[64];
  std::snprintf(name, sizeof(name), "step_%08lld.ckpt", static_cast<long long>(iteration));
  return name;
}

std::vector<std::string> list_checkpoints(const std::string& run_dir) {
  std::vector<std::string> files;
  const auto dir = std::filesystem::path(run_dir) / "checkpoints";
  std::error_code ec;
  if (!std::filesystem::is_directory(dir, ec)) return files;
  for (const auto& entry : std::filesystem::directory_iterator(dir, ec)) {
    const auto name = entry.path().filename().string();
    if (name.rfind("step_", 0) == 0 && entry.path().extension() == ".ckpt")
      files.push_back(entry.path().string());
  }
  // Newest first, by the step in the name read as a number: zero padding to 8 digits orders names
  // only up to step 99,999,999 (a name without a number sorts last; loading names the mismatch).
  const auto step_of = [](const std::string& path) -> long long {
    const std::string name = std::filesystem::path(path).stem().string().substr(5);
    if (name.empty() || name.size() > 18 || !std::all_of(name.begin(), name.end(), ::isdigit))
      return -1;
    return std::stoll(name);
  };
  std::sort(files.begin(), files.end(), [&](const std::string& a, const std::string& b) {
    const long long sa = step_of(a), sb = step_of(b);
    return sa != sb ? sa > sb : a > b;
  });
  return files;
}

std::string latest_checkpoint(const std::string& run_dir) {
  const auto files = list_checkpoints(run_dir);
  return files.empty() ? "" : files.front();
}

std::string resolve_checkpoint_path(const std::string& path) {
  if (std::filesystem::is_directory(path)) {
    const auto latest = latest_checkpoint(path);
    require(!latest.empty(), path + ": no checkpoints/step_*.ckpt in this run folder");
    return latest;
  }
  require(std::filesystem::exists(path), path + ": checkpoint not found");
  return path;
}

OpenedCheckpoint open_checkpoint(const std::string& path) {
  OpenedCheckpoint out;
  out.path = resolve_checkpoint_path(path);
  out.checkpoint = load_checkpoint(out.path);
  spdlog::info("checkpoint: {} (step {})", out.path,
               out.checkpoint.meta.value("iteration", int64_t{-1}));
  return out;
}

}  // namespace handscs
