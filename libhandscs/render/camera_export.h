// Cameras of rendered frames in a format other tools read: nerfstudio's transforms.json, so a user
// can show the same views in another viewer or train another method on the frames.
//
// Conventions written (nerfstudio's data format, camera_model OPENCV):
//   transform_matrix: camera-to-world 4x4 in OpenGL axes (x right, y up, z backwards), metres;
//     from ours (OpenCV: X_cam = R X_world + t, y down, z forwards) it is [R^T | -R^T t] with the
//     y and z columns negated.
//   fl_x, fl_y, cx, cy, w, h per frame: pixels; nerfstudio puts pixel (i, j)'s centre at
//     (i + 0.5, j + 0.5), as we do, so the principal point is copied unchanged. No distortion.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "core/camera.h"
#include "core/config.h"

namespace handscs {

// One rendered image: its file name (relative to the transforms.json) and its camera.
struct CameraFrame {
  std::string file_path;
  Camera camera;
};

json nerfstudio_transforms(const std::vector<CameraFrame>& frames);

// The camera a transforms.json frame describes, back in our convention (tests, importers).
Camera camera_from_nerfstudio_frame(const json& frame, const std::string& source);

}  // namespace handscs
