// Camera files for the renderer: {"K": 3x3, "R": 3x3, "t": [3], "width": W, "height": H} (OpenCV convention,
// X_cam = R X_world + t, metres), optionally "near" and "far" (m). K, R are nested row-major 3x3 arrays.
#pragma once

#include <string>

#include "core/camera.h"
#include "core/config.h"

namespace handscs {

// Parses a camera object; errors read "<source>: <key>: <problem>" and unknown keys are errors.
Camera camera_from_json(const json& object, const std::string& source);
// Reads a camera file (throws handscs::Error naming the file and key).
Camera read_camera_json(const std::string& path);
json camera_to_json(const Camera& camera);
// Writes a camera file atomically.
void write_camera_json(const std::string& path, const Camera& camera);

}  // namespace handscs
