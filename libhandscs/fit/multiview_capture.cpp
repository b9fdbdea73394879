#include "fit/multiview_capture.h"

#include <cmath>
#include <filesystem>
#include <set>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "core/config.h"
#include "hand/keypoint_order.h"
#include "data/neus_cameras.h"

namespace handscs {

namespace fs = std::filesystem;

namespace {

// The largest landmark coordinate taken: MediaPipe's normalised coordinates, mapped to [-1, 1] over
// the image, stray a little past its border for a hand at the edge.
constexpr double kMaxLandmark = 4.0;

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
      // Landmarks are the image's [-1, 1]; pixels, or a wild value, would be dropped one by one as
      // outliers and end in "no hand is seen", without the file.
      for (const json* value : {&x, &y})
        if (std::abs(value->get<double>()) > kMaxLandmark)
          throw Error(path + ": " + label + "[" + std::to_string(3 * src + (value == &x ? 0 : 1)) + "] = " +
                      fmt::format("{:.6g}", value->get<double>()) + ": landmarks are the image's [-1, 1] " +
                      "(one past " + fmt::format("{:g}", kMaxLandmark) +
                      " lies images away from it); are they pixels?");
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
  if (pose_dir.empty())
    throw Error(root + ": no landmark folder (pose/ or landmarks/, a NN.json of MediaPipe's landmarks "
                       "for each view NN; docs/FIT.md)");
  std::set<std::string> read;
  for (const NeusView& view : views.views) {
    // Detection::view indexes the views kept (a view without an image is left out).
    const int v = static_cast<int>(cap.views.size());
    cap.views.push_back(view.name);
    cap.cameras.push_back(view.camera);
    cap.images.push_back(view.image);
    cap.masks.push_back(view.mask);
    const std::string landmarks = neus_view_file(pose_dir, view.index, ".json");
    if (landmarks.empty()) continue;
    read.insert(fs::path(landmarks).filename().string());
    for (Detection& d : read_landmarks(landmarks, v, view.camera.width, view.camera.height))
      cap.detections.push_back(d);
  }
  if (read.empty())
    throw Error(pose_dir + ": no landmark file of any view (NN.json, numbered as the views' images)");
  // A file numbered for no view (no camera, or no image) is named rather than passed over.
  for (const auto& entry : fs::directory_iterator(pose_dir, ec))
    if (entry.path().extension() == ".json" && !read.count(entry.path().filename().string()))
      spdlog::warn("{}: no view of that number has a camera and an image; its landmarks are not used",
                   entry.path().string());
  return cap;
}

}  // namespace handscs
