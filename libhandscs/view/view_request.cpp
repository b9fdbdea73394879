#include "view/view_request.h"

#include "core/error.h"

namespace handscs {

namespace {

constexpr const char* kWhere = "request";

// "controls": one hand's values, or {"right": {...}, "left": {...}} (an object whose keys are hands).
void read_controls(const json& value, const std::string& path, ViewRequest& request) {
  bool by_hand = value.is_object() && !value.empty();
  for (auto it = value.begin(); by_hand && it != value.end(); ++it)
    by_hand = it.key() == "right" || it.key() == "left";
  if (!by_hand) {
    request.controls = controls_from_json(value, path);
    return;
  }
  for (auto it = value.begin(); it != value.end(); ++it) {
    const int side = it.key() == "right" ? 0 : 1;
    request.hand_controls[side] = controls_from_json(*it, path + "." + it.key());
  }
}

}  // namespace

ViewRequest parse_view_request(const std::string& body, const OrbitView& default_view) {
  require(body.size() <= kMaxViewRequestBytes,
          std::string(kWhere) + ": " + std::to_string(body.size()) + " bytes, more than " +
              std::to_string(kMaxViewRequestBytes));
  const json root = json::parse(body, nullptr, false);
  require(!root.is_discarded(), std::string(kWhere) + ": not valid JSON");
  require(root.is_object(), std::string(kWhere) + ": expected a JSON object, got " + json_type_name(root));
  ViewRequest request;
  int sources = 0;
  for (auto it = root.begin(); it != root.end(); ++it) {
    const std::string& key = it.key();
    const std::string path = std::string(kWhere) + "." + key;
    if (key == "controls") {
      request.source = ViewRequest::Source::controls;
      read_controls(*it, path, request);
      ++sources;
    } else if (key == "held_out") {
      require(it->is_number_integer(), path + ": expected an integer, got " + json_type_name(*it));
      request.source = ViewRequest::Source::held_out;
      request.held_out = it->get<int64_t>();
      ++sources;
    } else if (key == "pose") {
      request.source = ViewRequest::Source::pose;
      request.pose = pose_frame_from_json(*it, path);
      ++sources;
    } else if (key == "view") {
      request.view = orbit_view_from_json(*it, path, default_view);
    } else if (key == "format") {
      require(it->is_string() && (*it == "jpeg" || *it == "png"),
              path + ": expected \"jpeg\" or \"png\", got " + it->dump());
      request.format = *it == "png" ? ImageFormat::png : ImageFormat::jpeg;
    } else if (key == "quality") {
      require(it->is_number_integer(), path + ": expected an integer, got " + json_type_name(*it));
      const int64_t q = it->get<int64_t>();
      require(q >= kMinJpegQuality && q <= kMaxJpegQuality,
              path + ": " + std::to_string(q) + " is outside " + std::to_string(kMinJpegQuality) + ".." +
                  std::to_string(kMaxJpegQuality));
      request.quality = static_cast<int>(q);
    } else {
      throw Error(path + ": unknown key (controls, held_out, pose, view, format, quality)");
    }
  }
  require(sources <= 1, std::string(kWhere) + ": give one of controls, held_out and pose, not " +
                            std::to_string(sources));
  if (!root.contains("view")) request.view = default_view;
  return request;
}

}  // namespace handscs
