#include "data/capture_json.h"

namespace handscs {

using nlohmann::json;

json number_array(const double* values, int n) {
  json out = json::array();
  for (int i = 0; i < n; ++i) out.push_back(values[i]);
  return out;
}

json matrix_rows(const double* values, int rows, int cols) {
  json out = json::array();
  for (int r = 0; r < rows; ++r) out.push_back(number_array(values + r * cols, cols));
  return out;
}

json capture_camera_json(const Camera& camera) {
  return {{"K", matrix_rows(camera.K.data(), 3, 3)},
          {"R", matrix_rows(camera.R.data(), 3, 3)},
          {"t", number_array(camera.t.data(), 3)},
          {"width", camera.width},
          {"height", camera.height}};
}

json capture_hand_json(const double* pose, const double* shape, const double* trans, const double* joints) {
  json hand = {{"pose", number_array(pose, 48)}, {"shape", number_array(shape, 10)},
               {"trans", number_array(trans, 3)}};
  if (joints) hand["joints"] = matrix_rows(joints, 21, 3);
  return hand;
}

}  // namespace handscs
