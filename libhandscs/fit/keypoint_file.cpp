#include "fit/keypoint_file.h"

#include <algorithm>
#include <cmath>
#include <map>

#include <fmt/format.h>

#include "core/config.h"
#include "core/vec3.h"
#include "data/interhand_annotations.h"
#include "hand/joint_order.h"

namespace handscs {

namespace {

// Farthest a keypoint may lie from the origin: a wild value (1e300) made the fit's residual
// infinite. Far above millimetres read as metres (thousands), which the units check names.
constexpr double kMaxKeypointM = 1e6;

constexpr double kMaxMedianBoneM = 0.5;    // a 50 cm bone is no hand's: millimetres were given
constexpr double kMinMedianBoneM = 0.002;  // a 2 mm bone neither
constexpr double kMaxMillimetreBoneM = 500.0;  // nor a bone of 500 mm read as metres

std::optional<HandKeypoints> read_hand(const json& item, KeypointOrder order, double to_metres,
                                       const std::string& where) {
  if (item.is_null()) return std::nullopt;
  if (!item.is_array() || item.size() != 21)
    throw Error(where + ": expected an array of 21 points or null, got " + json_type_name(item) +
                (item.is_array() ? " of " + std::to_string(item.size()) : ""));
  std::array<double, 63> points{};
  std::array<uint8_t, 21> valid{};
  for (int j = 0; j < 21; ++j) {
    const json& p = item[j];
    const std::string at = where + "[" + std::to_string(j) + "]";
    if (p.is_null()) continue;
    if (!p.is_array() || p.size() != 3)
      throw Error(at + ": expected [x, y, z] or null, got " + json_type_name(p));
    for (int c = 0; c < 3; ++c) {
      if (!p[c].is_number()) throw Error(at + "[" + std::to_string(c) + "]: expected number, got " + json_type_name(p[c]));
      points[3 * j + c] = p[c].get<double>();
      if (std::abs(points[3 * j + c] * to_metres) > kMaxKeypointM)
        throw Error(at + "[" + std::to_string(c) + "]: " + fmt::format("{:.4g}", points[3 * j + c] * to_metres) +
                    " m from the origin: no keypoint of a hand lies beyond " +
                    fmt::format("{:g}", kMaxKeypointM) + " m");
    }
    valid[j] = 1;
  }
  HandKeypoints hand = keypoints_to_mano21(points, valid, order, to_metres);
  if (hand.num_valid() == 0) return std::nullopt;
  check_keypoint_units(hand, where);
  return hand;
}

}  // namespace

HandKeypoints keypoints_to_mano21(const std::array<double, 63>& points,
                                  const std::array<uint8_t, 21>& valid, KeypointOrder order,
                                  double to_metres) {
  const auto index = mano21_from_order(order);
  HandKeypoints hand;
  for (int j = 0; j < 21; ++j) {
    const int src = index[j];
    bool ok = valid[src] != 0;
    for (int c = 0; c < 3; ++c) ok = ok && std::isfinite(points[3 * src + c]);
    hand.valid[j] = ok ? 1 : 0;
    for (int c = 0; c < 3; ++c) hand.joints[3 * j + c] = ok ? points[3 * src + c] * to_metres : 0.0;
  }
  return hand;
}

void check_keypoint_units(const HandKeypoints& hand, const std::string& where) {
  std::vector<double> bones;
  for (int k = 1; k < 21; ++k) {
    const int parent = mano21_parent(k);
    if (!hand.valid[k] || !hand.valid[parent]) continue;
    const Vec3 a{hand.joints[3 * k], hand.joints[3 * k + 1], hand.joints[3 * k + 2]};
    const Vec3 b{hand.joints[3 * parent], hand.joints[3 * parent + 1], hand.joints[3 * parent + 2]};
    bones.push_back(norm(a - b));
  }
  if (bones.size() < 3) return;
  std::nth_element(bones.begin(), bones.begin() + bones.size() / 2, bones.end());
  const double median = bones[bones.size() / 2];
  const std::string length = fmt::format("{:.4g}", median);
  if (median > kMaxMillimetreBoneM)
    throw Error(where + ": the hand's median bone is " + length + " m long: too large for a hand in any unit");
  if (median > kMaxMedianBoneM)
    throw Error(where + ": the hand's median bone is " + length +
                " m long: the keypoints look like millimetres (set \"units\": \"mm\")");
  if (median < kMinMedianBoneM)
    throw Error(where + ": the hand's median bone is " + length +
                " m long: too small for a hand (are the units right, or the points all one?)");
}

std::vector<KeypointFrame> read_keypoint_file(const std::string& path) {
  const json doc = parse_json_file(path);
  if (!doc.is_object()) throw Error(path + ": expected a JSON object");
  for (const auto& [key, value] : doc.items())
    if (key != "format" && key != "order" && key != "units" && key != "frames")
      throw Error(path + ": unknown key \"" + key + "\" (known: format, order, units, frames)");
  if (doc.value("format", "") != "handscs-keypoints")
    throw Error(path + ": format: expected \"handscs-keypoints\"");
  if (!doc.contains("order") || !doc["order"].is_string())
    throw Error(path + ": order: missing; name the joint order (" + "mano21, interhand, mediapipe, openpose)");
  const KeypointOrder order = keypoint_order_from_name(doc["order"].get<std::string>(), path + ": order");
  if (!doc.contains("units") || !doc["units"].is_string())
    throw Error(path + ": units: missing; say \"m\" or \"mm\"");
  const std::string units = doc["units"].get<std::string>();
  if (units != "m" && units != "mm") throw Error(path + ": units: expected \"m\" or \"mm\", got \"" + units + "\"");
  const double to_metres = units == "mm" ? 1e-3 : 1.0;
  if (!doc.contains("frames") || !doc["frames"].is_array() || doc["frames"].empty())
    throw Error(path + ": frames: expected a non-empty array");
  std::vector<KeypointFrame> frames;
  std::map<std::string, size_t> first_of_name;
  for (size_t f = 0; f < doc["frames"].size(); ++f) {
    const json& item = doc["frames"][f];
    const std::string where = path + ": frames[" + std::to_string(f) + "]";
    if (!item.is_object()) throw Error(where + ": expected object");
    for (const auto& [key, value] : item.items())
      if (key != "name" && key != "right" && key != "left")
        throw Error(where + ": unknown key \"" + key + "\" (known: name, right, left)");
    KeypointFrame frame;
    if (item.contains("name") && !item["name"].is_string())
      throw Error(where + ".name: expected a string, got " + json_type_name(item["name"]));
    frame.name = item.contains("name") ? item["name"].get<std::string>() : "frame_" + std::to_string(f);
    // Names key the POSES files' frames and the report's rows: two frames of one name would mix.
    if (const auto first = first_of_name.emplace(frame.name, f); !first.second)
      throw Error(where + ".name: \"" + frame.name + "\" is also frames[" +
                  std::to_string(first.first->second) + "]'s name; each frame needs its own");
    if (item.contains("right")) frame.right = read_hand(item["right"], order, to_metres, where + ".right");
    if (item.contains("left")) frame.left = read_hand(item["left"], order, to_metres, where + ".left");
    frames.push_back(std::move(frame));
  }
  return frames;
}

std::vector<KeypointFrame> read_interhand_keypoints(const std::string& path, int capture) {
  const auto joints = read_interhand_joints(path, capture);
  std::vector<KeypointFrame> frames;
  for (const auto& [frame_idx, entry] : joints) {
    KeypointFrame frame;
    frame.name = "capture" + std::to_string(capture) + "_frame" + std::to_string(frame_idx);
    const std::string where = path + ": " + std::to_string(capture) + "." + std::to_string(frame_idx);
    for (int side = 0; side < 2; ++side) {
      const bool right = side == 0;
      if (entry.hand_type != "interacting" && entry.hand_type != (right ? "right" : "left")) continue;
      std::array<double, 63> points{};
      std::array<uint8_t, 21> valid{};
      for (int j = 0; j < 21; ++j) {
        valid[j] = entry.valid[21 * side + j];
        for (int c = 0; c < 3; ++c) points[3 * j + c] = entry.world_mm[3 * (21 * side + j) + c];
      }
      HandKeypoints hand = keypoints_to_mano21(points, valid, KeypointOrder::interhand, 1e-3);
      if (hand.num_valid() == 0) continue;
      check_keypoint_units(hand, where + (right ? " right" : " left"));
      (right ? frame.right : frame.left) = hand;
    }
    frames.push_back(std::move(frame));
  }
  return frames;
}

}  // namespace handscs
