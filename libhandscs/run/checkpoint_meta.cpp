#include "run/checkpoint_meta.h"

#include <cmath>
#include <filesystem>
#include <regex>

#include "core/error.h"
#include "data/capture_identity.h"
#include "data/placement.h"
#include "run/checkpoint.h"

namespace handscs {

namespace {

using json = nlohmann::json;

const json& field(const json& meta, const std::string& key, const std::string& source) {
  const auto it = meta.find(key);
  if (it == meta.end()) throw Error(source + ": checkpoint metadata lacks '" + key + "'");
  return *it;
}

int64_t integer_field(const json& meta, const std::string& key, const std::string& source,
                      int64_t low, int64_t high) {
  const json& v = field(meta, key, source);
  if (!v.is_number_integer())
    throw Error(source + ": checkpoint metadata '" + key + "' is " + v.dump() + ", not an integer");
  const int64_t x = v.is_number_unsigned() && v.get<uint64_t>() > static_cast<uint64_t>(INT64_MAX)
                        ? INT64_MAX
                        : v.get<int64_t>();
  if (x < low || x > high)
    throw Error(source + ": checkpoint metadata '" + key + "' is " + v.dump() + ", outside [" +
                std::to_string(low) + ", " + std::to_string(high) + "]");
  return x;
}

double number_field(const json& meta, const std::string& key, const std::string& source) {
  const json& v = field(meta, key, source);
  if (!v.is_number() || !std::isfinite(v.get<double>()))
    throw Error(source + ": checkpoint metadata '" + key + "' is " + v.dump() +
                ", not a finite number");
  return v.get<double>();
}

}  // namespace

void check_checkpoint_meta(const json& meta, const std::string& source) {
  if (!meta.is_object()) throw Error(source + ": checkpoint metadata is not an object");
  const json& format = field(meta, "format", source);
  if (format != "handscs-checkpoint")
    throw Error(source + ": checkpoint metadata 'format' is " + format.dump() +
                ", not \"handscs-checkpoint\" (not a HandSCS training checkpoint)");
  const json& version = field(meta, "version", source);
  if (version != kCheckpointVersion)
    throw Error(source + ": checkpoint format version " + version.dump() + "; this build reads " +
                std::to_string(kCheckpointVersion));
  const json& config = field(meta, "config", source);
  const auto train = config.is_object() ? config.find("train") : config.end();
  if (!config.is_object() || train == config.end() || !train->is_object() ||
      !train->contains("iterations"))
    throw Error(source + ": checkpoint metadata 'config' is not a run config (no train.iterations)");
  const int64_t planned = integer_field(*train, "iterations", source + " (stored config: train)", 1,
                                        INT64_MAX);
  const int64_t iteration = integer_field(meta, "iteration", source, 0, planned);
  integer_field(meta, "adam_steps", source, 0, INT64_MAX);
  const double lr_scale = number_field(meta, "lr_scale", source);
  if (!(lr_scale > 0 && lr_scale <= 1))
    throw Error(source + ": checkpoint metadata 'lr_scale' is " + std::to_string(lr_scale) +
                ", outside (0, 1]");
  // Counters the first checkpoints did not have: checked where present.
  for (const char* counter : {"skipped_steps", "rollbacks"})
    if (meta.contains(counter)) integer_field(meta, counter, source, 0, INT64_MAX);
  if (meta.contains("running_psnr")) number_field(meta, "running_psnr", source);
  if (meta.contains("elapsed_seconds") && number_field(meta, "elapsed_seconds", source) < 0)
    throw Error(source + ": checkpoint metadata 'elapsed_seconds' is negative");
  if (meta.contains(kCaptureIdentityKey))
    CaptureIdentity::from_json(meta.at(kCaptureIdentityKey),
                               source + ": checkpoint metadata " + kCaptureIdentityKey);
  if (meta.contains(kPlacementKey) && !meta.at(kPlacementKey).is_object())
    throw Error(source + ": checkpoint metadata '" + kPlacementKey + "' is " + meta.at(kPlacementKey).dump() +
                ", not an object");
  // A run's checkpoint is found by its name: the name must say the step it holds.
  const std::string name = std::filesystem::path(source).filename().string();
  static const std::regex run_name("step_[0-9]{8,}\\.ckpt");
  if (std::regex_match(name, run_name) && name != checkpoint_name(iteration))
    throw Error(source + ": named for another step than the " + std::to_string(iteration) +
                " it holds (renamed?)");
}

}  // namespace handscs
