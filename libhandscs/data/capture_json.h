// The JSON pieces of the project's capture.json (docs/CAPTURE_FORMAT.md) for the programs that
// write one: the synthetic capture generator and the keypoint fit.
#pragma once

#include <nlohmann/json.hpp>

#include "core/camera.h"

namespace handscs {

nlohmann::json number_array(const double* values, int n);
nlohmann::json matrix_rows(const double* values, int rows, int cols);

// {"K", "R", "t", "width", "height"} of one camera.
nlohmann::json capture_camera_json(const Camera& camera);

// {"pose": [48], "shape": [10], "trans": [3]} and, when joints is not null, "joints": [21][3].
nlohmann::json capture_hand_json(const double* pose, const double* shape, const double* trans,
                                 const double* joints);

}  // namespace handscs
