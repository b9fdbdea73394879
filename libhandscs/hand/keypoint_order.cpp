#include "hand/keypoint_order.h"

#include "core/error.h"
#include "hand/lbs.h"  // kInterHandFromMano21

namespace handscs {

KeypointOrder keypoint_order_from_name(const std::string& name, const std::string& where) {
  if (name == "mano21") return KeypointOrder::mano21;
  if (name == "interhand") return KeypointOrder::interhand;
  if (name == "mediapipe" || name == "openpose") return KeypointOrder::mediapipe;
  throw Error(where + ": unknown keypoint order \"" + name +
              "\" (known: mano21, interhand, mediapipe, openpose)");
}

std::string keypoint_order_name(KeypointOrder order) {
  switch (order) {
    case KeypointOrder::mano21: return "mano21";
    case KeypointOrder::interhand: return "interhand";
    case KeypointOrder::mediapipe: return "mediapipe";
  }
  return "mano21";
}

std::vector<std::string> keypoint_order_names() { return {"mano21", "interhand", "mediapipe"}; }

std::array<int, 21> mano21_from_order(KeypointOrder order) {
  std::array<int, 21> index{};
  switch (order) {
    case KeypointOrder::mano21:
      for (int i = 0; i < 21; ++i) index[i] = i;
      break;
    case KeypointOrder::interhand:
      // kInterHandFromMano21 maps InterHand rows to MANO21 joints; invert it.
      for (int i = 0; i < 21; ++i) index[kInterHandFromMano21[i]] = i;
      break;
    case KeypointOrder::mediapipe:
      index = kMano21FromMediaPipe;
      break;
  }
  return index;
}

}  // namespace handscs
