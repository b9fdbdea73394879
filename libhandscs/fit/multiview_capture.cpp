#include "fit/multiview_capture.h"

#include <cmath>
#include <filesystem>

#include "core/config.h"
#include "hand/keypoint_order.h"
#include "data/neus_cameras.h"

namespace handscs {

namespace fs = std::filesystem;

namespace {

std::vector<Detection> read_landmarks(const std::string& path, int view, int width, int height) {
  const json doc = parse_json_file(path);
  if (!doc.is_object()) throw Error(path + ": expected an object {\"Left\": [...], \"Right\": [...]}");
  std::vector<Detection> out;
  for (const auto& [label, values] : doc.items()) {
    if (label != "Left" && label != "Right")
      throw Error(path + ": unknown key \"" + label + "\" (known: Left, Right)");
    if (!values.is_array()) throw Error(path + ": " + label + ": expected an array");
    if (values.empty()) continue;
    if (values.size() != 63)
      throw Error(path + ": " + label + ": expected 63 numbers (21 landmarks x 3), got " +
                  std::to_string(values.size()));
    Detection d;
    d.view = view;
    d.label = label;
    for (int j = 0; j < 21; ++j) {
      const int src = kMano21FromMediaPipe[j];
      const json& x = values[3 * src];
      const json& y = values[3 * src + 1];
      if (!x.is_number() || !y.is_number()) continue;  // a missing landmark
      d.pixels[j] = {(x.get<double>() + 1.0) * 0.5 * width, (y.get<double>() + 1.0) * 0.5 * height};
      d.valid[j] = std::isfinite(d.pixels[j][0]) && std::isfinite(d.pixels[j][1]) ? 1 : 0;
    }
    out.push_back(d);
  }
  return out;
}

}  // namespace

MultiviewCapture read_multiview_capture(const std::string& root) {
  MultiviewCapture cap;
  cap.root = root;
  const NeusViews views = read_neus_views(root);
  std::error_code ec;
  std::string pose_dir;
  for (const char* name : {"pose", "landmarks"})
    if (pose_dir.empty() && fs::is_directory(fs::path(root) / name, ec)) pose_dir = (fs::path(root) / name).string();
  for (const NeusView& view : views.views) {
    // Detection::view indexes the views kept (a view without an image is left out).
    const int v = static_cast<int>(cap.views.size());
    cap.views.push_back(view.name);
    cap.cameras.push_back(view.camera);
    cap.images.push_back(view.image);
    cap.masks.push_back(view.mask);
    const std::string landmarks = neus_view_file(pose_dir, view.index, ".json");
    if (!landmarks.empty())
      for (Detection& d : read_landmarks(landmarks, v, view.camera.width, view.camera.height))
        cap.detections.push_back(d);
  }
  return cap;
}

}  // namespace handscs
