#include "run/run_config.h"

#include <cstdio>

#include "core/config.h"
#include "core/error.h"
#include "data/capture.h"

namespace handscs {

const std::vector<DeprecatedKey>& RunConfig::deprecated_keys() {
  static const std::vector<DeprecatedKey> keys = {
      {"model.rig", "data.rig", "masks and avatar are posed with one rig"},
      {"model.flat_hand_mean", "data.flat_hand_mean", "masks and avatar read poses alike"}};
  return keys;
}

Rig avatar_rig(const RunConfig& config, Handedness side) { return capture_rig(config.data, side); }

Handedness avatar_hand(const RunConfig& config, const std::string& what) {
  return single_hand(config.data.hand, what);
}

std::vector<std::string> experiment_differences(const RunConfig& stored, const RunConfig& given) {
  // Caches, prefetching, crop margins and mask refinement change how images are read, not which.
  static const char* kIdentity[] = {"root",         "split",           "capture",
                                    "sequences",    "hand",            "include_interacting",
                                    "train_cameras", "test_cameras",   "frame_stride",
                                    "drop_monochrome", "skip_black_images", "split_rule",
                                    "held_out_poses", "train_poses",   "validation_poses",
                                    "validation_cameras",
                                    "novel_view_train_views", "novel_view_test_views", "rig",
                                    "flat_hand_mean"};
  RunConfig a = stored, b = given;
  const json all_a = config_to_json(a.data), all_b = config_to_json(b.data);
  json id_a = json::object(), id_b = json::object();
  for (const char* key : kIdentity) {
    id_a[key] = all_a.at(key);
    id_b[key] = all_b.at(key);
  }
  return json_differences(id_a, id_b, "data");
}

void validate_run_config(const RunConfig& config, const std::string& source) {
  require(config.data.rig == config.model.rig,
          source + ": data.rig (\"" + config.data.rig + "\") and model.rig (\"" + config.model.rig +
              "\") must name the same rig: masks and avatar are posed with it");
  require(config.data.flat_hand_mean == config.model.flat_hand_mean,
          source + ": data.flat_hand_mean and model.flat_hand_mean must agree");
  require(!config.model.shared_decoders || config.data.hand == CaptureConfig::Hands::both,
          source + ": model.shared_decoders shares the decoders between two hands; it needs data.hand both");
  require(config.model.opacity_init_min <= config.model.opacity_init_max,
          source + ": model.opacity_init_min must not exceed model.opacity_init_max");
  require(config.train.densify.start <= config.train.densify.stop,
          source + ": train.densify.start must not exceed train.densify.stop");
  require(config.train.lr.means_final <= config.train.lr.means,
          source + ": train.lr.means_final must not exceed train.lr.means");
  const auto& loss = config.train.loss;
  require(loss.rgb > 0 || loss.mask > 0 || loss.ssim > 0 || loss.lpips > 0 || loss.reg > 0 ||
              loss.consistency > 0,
          source + ": train.loss: every weight (rgb, mask, ssim, lpips, reg, consistency) is 0, "
                   "so nothing would be learnt");
  check_eval_background(config, source);
  require(!config.data.mask_refine.enabled ||
              config.data.mask_refine.low < config.data.mask_refine.high,
          source + ": data.mask_refine.low (" + std::to_string(config.data.mask_refine.low) +
              ") must be below data.mask_refine.high (" +
              std::to_string(config.data.mask_refine.high) + "), or every mask would be empty");
}

void check_eval_background(const RunConfig& config, const std::string& source) {
  for (double v : config.eval.background) {
    char value[32];
    std::snprintf(value, sizeof(value), "%g", v);
    require(v >= 0 && v <= 1,
            source + ": eval.background: values must be in [0, 1] (got " + value + ")");
  }
}

}  // namespace handscs
