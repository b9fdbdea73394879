#include "fit/multiview_capture.h"

#include <cmath>
#include <filesystem>
#include <map>
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
  const std::map<int64_t, std::string> folders = neus_frame_folders(root);
  cap.sequence = !(folders.size() == 1 && folders.begin()->second == root);
  // Every instant's views; the capture's views are their union, one camera each.
  std::map<int64_t, NeusViews> views_of;
  std::map<int, NeusView> first_seen;  // by view index
  for (const auto& [frame, folder] : folders) {
    NeusViews& views = views_of[frame] = read_neus_views(root, cap.sequence ? folder : "");
    for (const NeusView& view : views.views) {
      const auto [it, fresh] = first_seen.emplace(view.index, view);
      const Camera& known = it->second.camera;
      if (!fresh && (known.width != view.camera.width || known.height != view.camera.height))
        throw Error(view.image + ": " + std::to_string(view.camera.width) + " x " +
                    std::to_string(view.camera.height) + " px, but view " + view.name + " is " +
                    std::to_string(known.width) + " x " + std::to_string(known.height) + " in " +
                    it->second.image + " (one camera per view: every instant's image must have its size)");
    }
  }
  std::map<int, int> position;  // view index -> position in cap.views (Detection::view)
  for (const auto& [index, view] : first_seen) {
    position[index] = static_cast<int>(cap.views.size());
    cap.views.push_back(view.name);
    cap.cameras.push_back(view.camera);
  }
  std::error_code ec;
  for (const auto& [frame, folder] : folders) {
    std::string pose_dir;
    for (const char* name : {"pose", "landmarks"})
      if (pose_dir.empty() && fs::is_directory(fs::path(folder) / name, ec)) pose_dir = (fs::path(folder) / name).string();
    if (pose_dir.empty()) {
      if (!cap.sequence)
        throw Error(root + ": no landmark folder (pose/ or landmarks/, a NN.json of MediaPipe's landmarks "
                           "for each view NN; docs/FIT.md)");
      spdlog::warn("{}: no landmark folder (pose/ or landmarks/): frame {} is not fitted", folder, frame);
      continue;
    }
    MultiviewInstant instant;
    instant.frame = frame;
    instant.images.resize(cap.views.size());
    instant.masks.resize(cap.views.size());
    std::set<std::string> read;
    for (const NeusView& view : views_of.at(frame).views) {
      const int v = position.at(view.index);
      instant.images[v] = view.image;
      instant.masks[v] = view.mask;
      const std::string landmarks = neus_view_file(pose_dir, view.index, ".json");
      if (landmarks.empty()) continue;
      read.insert(fs::path(landmarks).filename().string());
      for (Detection& d : read_landmarks(landmarks, v, view.camera.width, view.camera.height))
        instant.detections.push_back(d);
    }
    // A file numbered for no view (no camera, or no image) is named rather than passed over.
    for (const auto& entry : fs::directory_iterator(pose_dir, ec))
      if (entry.path().extension() == ".json" && !read.count(entry.path().filename().string()))
        spdlog::warn("{}: no view of that number has a camera and an image; its landmarks are not used",
                     entry.path().string());
    if (read.empty()) {
      const std::string what = pose_dir + ": no landmark file of any view (NN.json, numbered as the views' images)";
      if (!cap.sequence) throw Error(what);
      spdlog::warn("{}: frame {} is not fitted", what, frame);
      continue;
    }
    cap.instants.push_back(std::move(instant));
  }
  if (cap.instants.empty())
    throw Error(root + ": no frame folder holds landmarks (<frame>/pose/NN.json, MediaPipe's landmarks for "
                       "each view NN; docs/FIT.md)");
  return cap;
}

}  // namespace handscs
