// nerfstudio's transforms.json from our cameras and back: see camera_export.h.
#include "render/camera_export.h"

#include "core/error.h"

namespace handscs {

namespace {

// OpenCV camera axes -> OpenGL camera axes: y and z flip.
constexpr std::array<double, 3> kOpenGlAxes = {1.0, -1.0, -1.0};

}  // namespace

json nerfstudio_transforms(const std::vector<CameraFrame>& frames) {
  json list = json::array();
  for (const CameraFrame& f : frames) {
    const Camera& c = f.camera;
    const std::array<double, 3> centre = c.centre();
    json matrix = json::array();
    for (int row = 0; row < 3; ++row) {
      // Row `row` of R^T is column `row` of R; column k scaled by the axis flip.
      json values = json::array();
      for (int k = 0; k < 3; ++k) values.push_back(c.R[k * 3 + row] * kOpenGlAxes[k]);
      values.push_back(centre[row]);
      matrix.push_back(values);
    }
    matrix.push_back({0.0, 0.0, 0.0, 1.0});
    list.push_back({{"file_path", f.file_path},
                    {"transform_matrix", matrix},
                    {"fl_x", c.fx()},
                    {"fl_y", c.fy()},
                    {"cx", c.cx()},
                    {"cy", c.cy()},
                    {"w", c.width},
                    {"h", c.height}});
  }
  return {{"camera_model", "OPENCV"}, {"frames", list}};
}

Camera camera_from_nerfstudio_frame(const json& frame, const std::string& source) {
  try {
    const json& m = frame.at("transform_matrix");
    Camera c;
    c.width = frame.at("w").get<int>();
    c.height = frame.at("h").get<int>();
    c.K = {frame.at("fl_x").get<double>(), 0, frame.at("cx").get<double>(),
           0, frame.at("fl_y").get<double>(), frame.at("cy").get<double>(), 0, 0, 1};
    // R = (camera-to-world rotation with the axis flip undone)^T; t = -R centre.
    std::array<double, 3> centre{};
    for (int row = 0; row < 3; ++row) {
      for (int k = 0; k < 3; ++k)
        c.R[k * 3 + row] = m.at(row).at(k).get<double>() * kOpenGlAxes[k];
      centre[row] = m.at(row).at(3).get<double>();
    }
    for (int row = 0; row < 3; ++row)
      c.t[row] = -(c.R[row * 3] * centre[0] + c.R[row * 3 + 1] * centre[1] +
                   c.R[row * 3 + 2] * centre[2]);
    return c;
  } catch (const json::exception& e) {
    throw Error(source + ": not a transforms.json frame (" + e.what() + ")");
  }
}

}  // namespace handscs
