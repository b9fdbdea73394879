// POSES files for handscs-render: the hand poses to render, from one of three JSON forms:
//   {"poses": [{"pose": [48], "shape": [10], "trans": [3]}, ...]}      (a bare list works too)
//     two hands (a data.hand both avatar): {"right": {pose...}, "left": {pose...}} per pose
//   {"interpolate": {"from": {pose...}, "to": {pose...}, "steps": N}}  (per-joint slerp, linear trans/shape;
//     two hands: "from" and "to" are two-hand poses with the same hands)
//   {"capture": {CaptureConfig keys}, "frames": "test"|"train"|"all", "camera": "id", "max_frames": N}
//   a keypoint file (fit/keypoint_file.h: "format": "handscs-keypoints"): the avatar's rig fitted to
//   the hand it is (right or left) in every frame that has it, each hand's for a two-hand avatar
//   (docs/FIT.md)
// Poses are MANO axis-angle (relative to hands_mean unless the model is flat_hand_mean); shape and
// trans default to zeros. A capture selection also provides each frame's camera.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "core/camera.h"
#include "core/config.h"
#include "data/capture.h"  // HandParams
#include "hand/rig.h"
#include "run/avatar_state_io.h"

namespace handscs {

struct PoseFrame {
  std::array<float, 48> pose{};
  std::array<float, 10> shape{};
  std::array<float, 3> trans{};
  std::optional<Camera> camera;  // from a capture selection
  std::string camera_id;         // ... and that camera's id (its colour transform, if trained)
  std::string name;              // e.g. "pose_0003" or the capture image's name
  // Two hands: each hand's parameters by Handedness (right, left), absent where the pose lacks it
  // (the fields above then hold the first present hand's); empty for a one-hand pose.
  std::array<std::optional<HandParams>, 2> hands;
};

// What a keypoint file is fitted for: the avatar's rigs by Handedness (right, left; null for a hand
// it lacks) and its pose convention. With two rigs every frame holds each hand the file has.
struct KeypointTarget {
  std::array<const Rig*, 2> rigs{};
  bool flat_hand_mean = false;
};

// The target of a trained avatar: its hands' rigs.
KeypointTarget keypoint_target(TrainedAvatar& trained);

// Checks that the poses read from `path` fit the avatar's hands. Throws Error for a one-hand pose
// on a two-hand avatar, and for a two-hand pose without a one-hand avatar's own hand (the other
// hand's parameters would pose it). Warns once when poses also give a hand the avatar lacks (not
// drawn).
void check_poses_for_avatar(const std::vector<PoseFrame>& poses, const TrainedAvatar& trained,
                            const std::string& path);

// The poses of `path` (a POSES or keypoint file) for `trained`: read through its keypoint target,
// then checked against its hands (check_poses_for_avatar).
std::vector<PoseFrame> read_poses_for_avatar(const std::string& path, TrainedAvatar& trained);

// Reads a POSES file; errors name the file and the key path (e.g. "poses[2].pose: expected 48
// numbers, got 45"). A keypoint file needs `target`.
std::vector<PoseFrame> read_pose_source(const std::string& path, const KeypointTarget& target = {});

// One pose object {"pose": [48], "shape": [10], "trans": [3], "name": "..."}, or of two hands
// {"right": {pose...}, "left": {pose...}, "name": "..."} (either hand may be left out), with the checks every
// POSES file gets (numbers finite, within the MANO annotations' plausibility bounds, mano_problem);
// errors start with `where` (e.g. "poses.json: poses[2]").
PoseFrame pose_frame_from_json(const json& item, const std::string& where);
// The same object for a frame (pose, shape, trans and a non-empty name), numbers exact for a float.
json pose_frame_to_json(const PoseFrame& frame);

// Per-joint spherical interpolation of axis-angle poses (t in [0, 1]); shape and trans linear; each
// hand of two-hand poses (Error when the two hold different hands).
PoseFrame interpolate_pose(const PoseFrame& a, const PoseFrame& b, double t);

}  // namespace handscs
