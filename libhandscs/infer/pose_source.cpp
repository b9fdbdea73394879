#include "infer/pose_source.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "core/atomic_file.h"
#include "core/config.h"
#include "core/error.h"
#include "data/capture.h"
#include "data/interhand_annotations.h"
#include "data/placement.h"
#include "fit/keypoint_file.h"
#include "hand/joint_model.h"
#include "hand/keypoint_fit.h"

namespace handscs {

namespace {

template <size_t N>
void read_numbers(const json& parent, const char* key, std::array<float, N>& out, bool required,
                  const std::string& where) {
  auto it = parent.find(key);
  if (it == parent.end()) {
    if (required) throw Error(where + "." + key + ": missing");
    return;
  }
  if (!it->is_array() || it->size() != N)
    throw Error(where + "." + key + ": expected " + std::to_string(N) + " numbers, got " +
                (it->is_array() ? std::to_string(it->size()) + " values" : json_type_name(*it)));
  for (size_t i = 0; i < N; ++i) {
    const auto& v = (*it)[i];
    if (!v.is_number())
      throw Error(where + "." + key + "[" + std::to_string(i) + "]: expected number, got " +
                  json_type_name(v));
    out[i] = v.get<float>();
    if (!std::isfinite(out[i]))
      throw Error(where + "." + key + "[" + std::to_string(i) + "]: not a finite number");
  }
}

// "where.key", or "file: key" for a top-level member (where = "file:").
std::string key_path(const std::string& where, const char* key) {
  return where + (!where.empty() && where.back() == ':' ? " " : ".") + key;
}

// Optional scalar members, checked: a value of another type is an error naming its key path
// (nlohmann's own type_error names neither file nor key).
int64_t integer_or(const json& parent, const char* key, int64_t fallback, const std::string& where) {
  auto it = parent.find(key);
  if (it == parent.end()) return fallback;
  if (!it->is_number_integer())
    throw Error(key_path(where, key) + ": expected an integer, got " + json_type_name(*it));
  return it->get<int64_t>();
}
std::string string_or(const json& parent, const char* key, const std::string& fallback,
                      const std::string& where) {
  auto it = parent.find(key);
  if (it == parent.end()) return fallback;
  if (!it->is_string()) throw Error(key_path(where, key) + ": expected a string, got " + json_type_name(*it));
  return it->get<std::string>();
}

// Axis-angle <-> unit quaternion (w, x, y, z).
std::array<double, 4> to_quat(const float* aa) {
  const double angle = std::sqrt(double(aa[0]) * aa[0] + double(aa[1]) * aa[1] + double(aa[2]) * aa[2]);
  if (angle < 1e-12) return {1, 0, 0, 0};
  const double s = std::sin(angle / 2) / angle;
  return {std::cos(angle / 2), aa[0] * s, aa[1] * s, aa[2] * s};
}
void from_quat(std::array<double, 4> q, float* aa) {
  if (q[0] < 0)
    for (auto& c : q) c = -c;
  const double v = std::sqrt(q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  const double angle = 2 * std::atan2(v, q[0]);
  const double s = v < 1e-12 ? 2.0 : angle / v;
  for (int i = 0; i < 3; ++i) aa[i] = static_cast<float>(q[i + 1] * s);
}

std::string numbered(const char* prefix, size_t i) {
  char name[64];
  std::snprintf(name, sizeof(name), "%s_%04zu", prefix, i);
  return name;
}

}  // namespace

PoseFrame pose_frame_from_json(const json& item, const std::string& where) {
  if (!item.is_object()) throw Error(where + ": expected object, got " + json_type_name(item));
  if (item.contains("right") || item.contains("left")) {
    PoseFrame frame;
    for (auto it = item.begin(); it != item.end(); ++it)
      if (it.key() != "right" && it.key() != "left" && it.key() != "name")
        throw Error(where + "." + it.key() + ": unknown key in a two-hand pose (right, left, name)");
    for (const Handedness side : {Handedness::left, Handedness::right}) {  // right's fields last
      const std::string key = hand_name(side);
      if (!item.contains(key) || item[key].is_null()) continue;
      const PoseFrame hand = pose_frame_from_json(item[key], where + "." + key);
      frame.pose = hand.pose;
      frame.shape = hand.shape;
      frame.trans = hand.trans;
      frame.hands[side == Handedness::right ? 0 : 1] = HandParams{hand.pose, hand.shape, hand.trans, {}, {}};
    }
    if (!frame.hands[0] && !frame.hands[1]) throw Error(where + ": both hands are null");
    frame.name = string_or(item, "name", "", where);
    return frame;
  }
  for (auto it = item.begin(); it != item.end(); ++it)
    if (it.key() != "pose" && it.key() != "shape" && it.key() != "trans" && it.key() != "name")
      throw Error(where + "." + it.key() + ": unknown key (pose, shape, trans, name)");
  PoseFrame frame;
  read_numbers(item, "pose", frame.pose, true, where);
  read_numbers(item, "shape", frame.shape, false, where);
  read_numbers(item, "trans", frame.trans, false, where);
  frame.name = string_or(item, "name", "", where);
  // The same plausibility bounds as the MANO annotations of a capture (mano_problem).
  ManoParams params;
  std::copy(frame.pose.begin(), frame.pose.end(), params.pose.begin());
  std::copy(frame.shape.begin(), frame.shape.end(), params.shape.begin());
  std::copy(frame.trans.begin(), frame.trans.end(), params.trans.begin());
  const std::string implausible = mano_problem(params);
  if (!implausible.empty()) throw Error(where + ": " + implausible);
  return frame;
}

json pose_frame_to_json(const PoseFrame& frame) {
  json item;
  if (frame.hands[0] || frame.hands[1]) {
    for (const Handedness side : {Handedness::right, Handedness::left})
      if (const auto& hand = frame.hands[side == Handedness::right ? 0 : 1])
        item[hand_name(side)] = hand_params_to_json(*hand);
  } else {
    item = hand_params_to_json(HandParams{frame.pose, frame.shape, frame.trans, {}, {}});
  }
  if (!frame.name.empty()) item["name"] = frame.name;
  return item;
}

namespace {

// Per-joint slerp of the poses, linear shape and trans: for a PoseFrame or one hand's HandParams.
template <class Hand>
void blend_hand(const Hand& a, const Hand& b, double t, Hand& out) {
  for (int j = 0; j < 16; ++j) {
    auto qa = to_quat(&a.pose[3 * j]);
    auto qb = to_quat(&b.pose[3 * j]);
    double dot = qa[0] * qb[0] + qa[1] * qb[1] + qa[2] * qb[2] + qa[3] * qb[3];
    if (dot < 0) {  // the shorter way round
      for (auto& c : qb) c = -c;
      dot = -dot;
    }
    std::array<double, 4> q;
    if (dot > 0.9995) {  // nearly equal: normalised lerp avoids dividing by sin(~0)
      for (int i = 0; i < 4; ++i) q[i] = qa[i] + t * (qb[i] - qa[i]);
    } else {
      const double theta = std::acos(dot);
      const double wa = std::sin((1 - t) * theta) / std::sin(theta);
      const double wb = std::sin(t * theta) / std::sin(theta);
      for (int i = 0; i < 4; ++i) q[i] = wa * qa[i] + wb * qb[i];
    }
    const double norm = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    for (auto& c : q) c /= norm;
    from_quat(q, &out.pose[3 * j]);
  }
  for (int i = 0; i < 10; ++i) out.shape[i] = float((1 - t) * a.shape[i] + t * b.shape[i]);
  for (int i = 0; i < 3; ++i) out.trans[i] = float((1 - t) * a.trans[i] + t * b.trans[i]);
}

}  // namespace

PoseFrame interpolate_pose(const PoseFrame& a, const PoseFrame& b, double t) {
  PoseFrame out;
  blend_hand(a, b, t, out);
  for (int side = 0; side < 2; ++side) {
    if (a.hands[side].has_value() != b.hands[side].has_value())
      throw Error("interpolate: \"from\" and \"to\" hold different hands");
    if (!a.hands[side]) continue;
    out.hands[side].emplace();
    blend_hand(*a.hands[side], *b.hands[side], t, *out.hands[side]);
  }
  return out;
}

namespace {

// An hour of video at 30 FPS is 108,000 frames; a longer interpolation is a typo, and would hold
// ~250 bytes per pose in memory before the first frame renders.
constexpr int kMaxInterpolationSteps = 1000000;

std::vector<PoseFrame> read_pose_source_json(const json& root, const std::string& path) {
  std::vector<PoseFrame> frames;
  // One motion source per file: with two, one would be ignored without a word.
  if (root.is_object()) {
    std::vector<std::string> sources;
    for (const char* key : {"poses", "interpolate", "capture"})
      if (root.contains(key)) sources.push_back(key);
    if (sources.size() > 1)
      throw Error(path + ": holds both \"" + sources[0] + "\" and \"" + sources[1] +
                  "\"; give one motion source per file");
  }
  if (root.is_array() || (root.is_object() && root.contains("poses"))) {
    const json& list = root.is_array() ? root : root["poses"];
    const std::string base = path + ": " + (root.is_array() ? std::string("") : std::string("poses"));
    if (!list.is_array()) throw Error(path + ": poses: expected array, got " + json_type_name(list));
    for (size_t i = 0; i < list.size(); ++i) {
      frames.push_back(pose_frame_from_json(list[i], base + "[" + std::to_string(i) + "]"));
      if (frames.back().name.empty()) frames.back().name = numbered("pose", i);
    }
  } else if (root.is_object() && root.contains("interpolate")) {
    const json& spec = root["interpolate"];
    const std::string where = path + ": interpolate";
    if (!spec.is_object()) throw Error(where + ": expected object, got " + json_type_name(spec));
    if (!spec.contains("from") || !spec.contains("to"))
      throw Error(where + ": needs \"from\" and \"to\" poses");
    const PoseFrame a = pose_frame_from_json(spec["from"], where + ".from");
    const PoseFrame b = pose_frame_from_json(spec["to"], where + ".to");
    const int64_t steps = integer_or(spec, "steps", 30, where);
    if (steps < 2 || steps > kMaxInterpolationSteps)
      throw Error(where + ".steps: between 2 and " + std::to_string(kMaxInterpolationSteps) +
                  ", got " + std::to_string(steps));
    for (int side = 0; side < 2; ++side)
      if (a.hands[side].has_value() != b.hands[side].has_value())
        throw Error(where + ": \"from\" has " + (a.hands[side] ? "" : "no ") + "\"" +
                    hand_name(side ? Handedness::left : Handedness::right) + "\" hand and \"to\" " +
                    (b.hands[side] ? "has one" : "has none") + "; give both the same hands");
    for (int i = 0; i < steps; ++i) {
      frames.push_back(interpolate_pose(a, b, double(i) / (steps - 1)));
      frames.back().name = numbered("pose", i);
    }
  } else if (root.is_object() && root.contains("capture")) {
    CaptureConfig capture_config;
    config_from_json(root["capture"], path + ": capture", capture_config);
    const std::string which = string_or(root, "frames", "test", path + ":");
    if (which != "test" && which != "train" && which != "all")
      throw Error(path + ": frames: expected \"test\", \"train\" or \"all\", got \"" + which + "\"");
    const std::string camera_id = string_or(root, "camera", "", path + ":");
    const int64_t max_frames = integer_or(root, "max_frames", 0, path + ":");
    Capture capture = Capture::open(capture_config, "", "capture");
    const auto& source = which == "test" ? capture.test() : which == "train" ? capture.train()
                                                                             : capture.frames();
    for (const auto& f : source) {
      if (!camera_id.empty() && f.camera_id != camera_id) continue;
      PoseFrame frame;
      frame.pose = f.pose;
      frame.shape = f.shape;
      frame.trans = f.trans;
      frame.hands = f.hands;
      frame.camera = f.camera;
      frame.camera_id = f.camera_id;
      frame.name = f.file_name;
      for (auto& c : frame.name)
        if (c == '/') c = '_';
      frame.name = frame.name.substr(0, frame.name.rfind('.'));
      frames.push_back(frame);
      if (max_frames > 0 && static_cast<int64_t>(frames.size()) >= max_frames) break;
    }
  } else {
    throw Error(path + ": expected {\"poses\": [...]}, {\"interpolate\": {...}} or {\"capture\": {...}}");
  }
  if (frames.empty()) throw Error(path + ": no poses selected");
  return frames;
}

// A keypoint file's hands fitted with the avatar's rigs: one frame per file frame that has a hand
// the avatar has. One rig: one-hand frames; two: frames with `hands` (each present hand's).
std::vector<PoseFrame> poses_from_keypoints(const std::string& path, const KeypointTarget& target) {
  const std::vector<KeypointFrame> file = read_keypoint_file(path);
  const bool two = target.rigs[0] && target.rigs[1];
  std::vector<PoseFrame> frames(file.size());
  std::vector<bool> fitted(file.size(), false);
  std::vector<std::string> missing;
  for (const Handedness side : {Handedness::left, Handedness::right}) {  // right's fields last
    const int slot = side == Handedness::right ? 0 : 1;
    const Rig* rig = target.rigs[slot];
    if (!rig) continue;
    std::vector<size_t> index;
    std::vector<HandKeypoints> hands;
    for (size_t i = 0; i < file.size(); ++i) {
      const auto& hand = side == Handedness::right ? file[i].right : file[i].left;
      if (hand && hand->num_valid() >= kMinFitKeypoints) {
        index.push_back(i);
        hands.push_back(*hand);
      }
    }
    if (hands.empty()) {
      missing.push_back(hand_name(side));
      continue;
    }
    const JointModel model = make_joint_model(*rig);
    const std::vector<HandFit> fits = fit_keypoint_sequence(model, hands, KeypointFitConfig{});
    double worst = 0;
    for (size_t k = 0; k < fits.size(); ++k) {
      HandParams params;
      const auto pose = rig_pose(model, fits[k].params, target.flat_hand_mean);
      for (int i = 0; i < kPoseDim; ++i) params.pose[i] = static_cast<float>(pose[i]);
      for (int i = 0; i < kShapeDim; ++i) params.shape[i] = static_cast<float>(fits[k].params.shape[i]);
      for (int i = 0; i < 3; ++i) params.trans[i] = static_cast<float>(fits[k].params.trans[i]);
      PoseFrame& frame = frames[index[k]];
      frame.pose = params.pose;
      frame.shape = params.shape;
      frame.trans = params.trans;
      if (two) frame.hands[slot] = params;
      frame.name = file[index[k]].name;
      fitted[index[k]] = true;
      worst = std::max(worst, fits[k].mean_mm);
    }
    spdlog::info("{}: {} frames of the {} hand fitted (largest mean residual {:.2f} mm)", path, fits.size(),
                 hand_name(side), worst);
  }
  if (missing.size() == static_cast<size_t>(two ? 2 : 1))
    throw Error(path + ": no frame holds the " + (two ? std::string("right or left") : missing.front()) +
                " hand (with 5 or more keypoints) that the avatar's rig" + (two ? "s" : "") + " can be fitted to");
  for (const std::string& side : missing)
    spdlog::warn("{}: no frame holds the {} hand; it is left out of every frame", path, side);
  std::vector<PoseFrame> out;
  for (size_t i = 0; i < frames.size(); ++i)
    if (fitted[i]) out.push_back(std::move(frames[i]));
  return out;
}

}  // namespace

std::vector<PoseFrame> read_pose_source(const std::string& path, const KeypointTarget& target) {
  const json root = parse_json_file(path);
  if (root.is_object() && root.value("format", "") == "handscs-keypoints") {
    require(target.rigs[0] || target.rigs[1],
            path + ": a keypoint file, which needs an avatar's rig to fit (use it with handscs-render or handscs-view, "
                   "or turn it into poses with handscs-fit)");
    return poses_from_keypoints(path, target);
  }
  try {
    return read_pose_source_json(root, path);
  } catch (const json::exception& e) {  // a value of another type than the key needs
    throw Error(path + ": " + e.what());
  }
}

KeypointTarget keypoint_target(TrainedAvatar& trained) {
  KeypointTarget target;
  for (const Handedness side : {Handedness::right, Handedness::left})
    if (const Avatar* avatar = trained.hand(side)) target.rigs[side == Handedness::right ? 0 : 1] = &avatar->rig();
  target.flat_hand_mean = trained.config.model.flat_hand_mean;
  return target;
}

void check_poses_for_avatar(const std::vector<PoseFrame>& poses, const TrainedAvatar& trained,
                            const std::string& path) {
  const std::vector<Handedness> sides = hand_sides(trained.trained_config.data.hand);
  if (sides.size() > 1) {
    for (size_t k = 0; k < poses.size(); ++k)
      if (!poses[k].hands[0] && !poses[k].hands[1])
        throw Error(path + ": pose " + std::to_string(k) + " is one hand's; the avatar has two (data.hand "
                    "both): give each pose as {\"right\": {...}, \"left\": {...}} or select a capture with "
                    "\"hand\": \"both\"");
    return;
  }
  const Handedness own = sides.front();
  const int own_slot = own == Handedness::right ? 0 : 1;
  int64_t with_other = 0;
  for (size_t k = 0; k < poses.size(); ++k) {
    const PoseFrame& f = poses[k];
    if (!f.hands[0] && !f.hands[1]) continue;  // a one-hand pose: the avatar's hand
    if (!f.hands[own_slot])
      throw Error(path + ": pose " + std::to_string(k) + " has no " + hand_name(own) +
                  " hand, and the avatar is the " + hand_name(own) + " hand's alone (data.hand " +
                  hand_name(own) + ")");
    if (f.hands[1 - own_slot]) ++with_other;
  }
  if (with_other > 0) {
    const Handedness other = other_hand(own);
    spdlog::warn("{}: {} of {} poses give the {} hand too; the avatar has the {} hand alone (data.hand "
                 "{}), so only that hand is drawn",
                 path, with_other, poses.size(), hand_name(other), hand_name(own), hand_name(own));
  }
}

std::vector<PoseFrame> read_poses_for_avatar(const std::string& path, TrainedAvatar& trained) {
  std::vector<PoseFrame> poses = read_pose_source(path, keypoint_target(trained));
  check_poses_for_avatar(poses, trained, path);
  return poses;
}

}  // namespace handscs
