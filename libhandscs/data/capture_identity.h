// What tells one capture from another once a run has trained on it. The split's keys (data.split,
// capture, held_out_poses, ...) match any capture of the same layout, so a data.root that names
// another capture would be scored as the run's own. A run stores the identity of its capture in
// its checkpoints; handscs-eval and a resume compare it with the capture they open.
//
// The identity hashes what a capture's files say about the frames the run selected (train and test
// alike): each frame's image name and camera, and its
// annotated hands (joints, and the MANO parameters when they are read, not fitted). A capture
// copied or moved keeps it; one synthesised with another seed, or another recording of the same
// layout, does not. Images are not read (a damaged one is refused at open all the same).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "data/capture.h"

namespace handscs {

// The key of a checkpoint's metadata that holds the identity (absent from older checkpoints).
inline constexpr const char* kCaptureIdentityKey = "capture_identity";

struct CaptureIdentity {
  int64_t frames = 0;        // Capture::frames(): the usable frames of the selection
  uint64_t calibration = 0;  // their cameras: ids, intrinsics, pose, image size
  uint64_t annotations = 0;  // their image names and annotated hands

  nlohmann::json to_json() const;
  // Throws Error naming `where` and the key when the object is malformed.
  static CaptureIdentity from_json(const nlohmann::json& object, const std::string& where);
};

// The identity of `frames`, frames of `capture` (order-independent: a sum of per-frame hashes). A
// run stores its Capture::frames(). A config without the run's data.validation_cameras opens the
// test cameras too; its Capture::train() then holds the run's frames.
CaptureIdentity capture_identity(const Capture& capture, const std::vector<FrameInfo>& frames);

// How `given` differs from `run`, as phrases for an error ("the cameras' calibration", ...); empty
// when the two are the same capture.
std::vector<std::string> identity_differences(const CaptureIdentity& run, const CaptureIdentity& given);

}  // namespace handscs
