#include "train/run_config.h"

#include "core/error.h"
#include "data/capture.h"

namespace handscs {

std::string avatar_rig_source(const RunConfig& config) {
  CaptureConfig data = config.data;
  data.rig = config.model.rig;
  return capture_rig_source(data);
}

void validate_run_config(const RunConfig& config, const std::string& source) {
  require(config.data.rig == config.model.rig,
          source + ": data.rig (\"" + config.data.rig + "\") and model.rig (\"" + config.model.rig +
              "\") must name the same rig: masks and avatar are posed with it");
  require(config.data.flat_hand_mean == config.model.flat_hand_mean,
          source + ": data.flat_hand_mean and model.flat_hand_mean must agree");
  require(config.model.opacity_init_min <= config.model.opacity_init_max,
          source + ": model.opacity_init_min must not exceed model.opacity_init_max");
  require(config.train.densify.start <= config.train.densify.stop,
          source + ": train.densify.start must not exceed train.densify.stop");
  require(config.train.lr.means_final <= config.train.lr.means,
          source + ": train.lr.means_final must not exceed train.lr.means");
}

}  // namespace handscs
