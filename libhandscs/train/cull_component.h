// train.cull as a training component: each entry decodes only the Gaussians that face one of its
// views' cameras (avatar/facing_cull.h), and logged steps report the share decoded.
#pragma once

#include "train/training_component.h"

namespace handscs {

class CullComponent : public TrainingComponent {
 public:
  explicit CullComponent(double max_cos) : max_cos_(max_cos) {}

  void before_decode(EntryContext& entry) override;
  void diagnostics(const EntryContext& entry, std::map<std::string, double>& values) override;
  std::vector<std::string> metrics_columns() const override;

 private:
  double max_cos_;  // train.cull.max_cos
};

}  // namespace handscs
