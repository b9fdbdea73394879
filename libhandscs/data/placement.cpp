#include "data/placement.h"

#include "core/error.h"

namespace handscs {

nlohmann::json hand_params_to_json(const HandParams& hand) {
  return {{"pose", hand.pose}, {"shape", hand.shape}, {"trans", hand.trans}};
}

nlohmann::json training_placement(const std::vector<FrameInfo>& train) {
  require(!train.empty(), "training_placement: no training frames");
  std::array<bool, 2> any{};
  for (const FrameInfo& frame : train)
    for (int side = 0; side < 2; ++side) any[side] = any[side] || frame.hands[side].has_value();
  const FrameInfo* chosen = &train.front();
  for (const FrameInfo& frame : train)
    if ((!any[0] || frame.hands[0]) && (!any[1] || frame.hands[1])) {
      chosen = &frame;
      break;
    }
  nlohmann::json placement;
  if (any[0] || any[1]) {
    for (int side = 0; side < 2; ++side)
      if (chosen->hands[side]) placement[side == 0 ? "right" : "left"] = hand_params_to_json(*chosen->hands[side]);
  } else {
    placement = hand_params_to_json(own_hand(*chosen));
  }
  placement["name"] = chosen->file_name;
  return placement;
}

}  // namespace handscs
