// Decode a pose once for every camera that shows it. Evaluation walks its frames pose by pose
// (a capture's frames are sorted by frame index, then camera) and an orbit shows one pose from many
// cameras: the avatar's pose-dependent work (LBS, SCS, the three decoders; most of a frame) is the
// same for all of them, only the rasterizer depends on the camera. The result is bit-identical to
// posing for every image (docs/BENCHMARKS.md#evaluation).
#pragma once

#include <array>
#include <optional>

#include "avatar/avatar.h"

namespace handscs {

class PoseMemo {
 public:
  explicit PoseMemo(Avatar& avatar) : avatar_(avatar) {}

  // The avatar posed at pose [48], shape [10], trans [3]: posed now when the values differ from the
  // previous call's (compared exactly), else the previous result. Call under inference mode.
  const AvatarState& pose(const float* pose, const float* shape, const float* trans);

  // Milliseconds the last computed pose took (so a cached one can still report its full cost).
  double pose_ms() const { return pose_ms_; }
  int64_t computed() const { return computed_; }  // poses computed so far
  int64_t reused() const { return reused_; }      // calls answered from the previous pose
  const AvatarState* last() const { return state_ ? &*state_ : nullptr; }  // the last call's

 private:
  static constexpr size_t kKeySize = 48 + 10 + 3;
  Avatar& avatar_;
  std::array<float, kKeySize> key_{};
  std::optional<AvatarState> state_;
  double pose_ms_ = 0;
  int64_t computed_ = 0, reused_ = 0;
};

// One hand's parameters for pose_side_by_side: pose [48], shape [10], trans [3]; null `pose` skips
// the hand.
struct HandPoseInput {
  const float* pose = nullptr;
  const float* shape = nullptr;
  const float* trans = nullptr;
};

// Poses each hand with its memo: on two threads at once when two hands need posing and OpenMP
// has two or more, else one after the other. A hand of a few thousand Gaussians is too small for
// LibTorch to spread its operations over threads, so two hands side by side is what keeps both
// cores busy (docs/TRAINING.md#what-a-second-hand-costs). Each worker runs under the caller's inference mode.
// Returns the states (null for a skipped hand).
std::array<const AvatarState*, 2> pose_side_by_side(const std::array<PoseMemo*, 2>& memos,
                                                    const std::array<HandPoseInput, 2>& hands);

// Whether pose_side_by_side poses these hands on two threads (both given, OpenMP has two or more).
bool poses_side_by_side(const std::array<PoseMemo*, 2>& memos, const std::array<HandPoseInput, 2>& hands);

}  // namespace handscs
