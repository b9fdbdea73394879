// A trained avatar's hands posed for one frame and joined into one set for the rasteriser, so that
// each hand hides the other where it is in front. One hand: its avatar alone, from the frame's
// pose fields. data.hand both: each hand the frame has (FrameInfo::hands, PoseFrame::hands), a
// missing hand left out. Each hand is posed once per pose (PoseMemo).
//
//   PosedHands hands(trained);
//   const PosedGaussians& posed = hands.pose(frame, "eval: " + frame.file_name);
//   render_posed(posed, camera, settings);
#pragma once

#include <array>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "avatar/avatar.h"
#include "avatar/pose_memo.h"
#include "core/error.h"
#include "data/capture.h"
#include "run/avatar_state_io.h"

namespace handscs {

class PosedHands {
 public:
  explicit PosedHands(TrainedAvatar& trained);

  // The frame's hands posed and joined (Frame: FrameInfo or PoseFrame). Throws Error starting with
  // `where` when a two-hand avatar's frame has neither hand, or a one-hand avatar's two-hand frame
  // lacks its hand (the other hand is not drawn). Call under inference mode.
  template <class Frame>
  const PosedGaussians& pose(const Frame& frame, const std::string& where) {
    std::array<const HandParams*, 2> hands{};
    if (two_hands_) {
      for (int side = 0; side < 2; ++side) hands[side] = frame.hands[side] ? &*frame.hands[side] : nullptr;
    } else if (frame.hands[0] || frame.hands[1]) {
      // A two-hand pose: the avatar's own hand, never the other's parameters in its place.
      const int own = first_ == Handedness::right ? 0 : 1;
      if (!frame.hands[own])
        throw Error(where + ": the pose has no " + hand_name(first_) + " hand, and the avatar is the " +
                    hand_name(first_) + " hand's alone (data.hand " + hand_name(first_) + ")");
      hands[own] = &*frame.hands[own];
    } else {
      one_.pose = frame.pose;
      one_.shape = frame.shape;
      one_.trans = frame.trans;
      hands[first_ == Handedness::right ? 0 : 1] = &one_;
    }
    return pose_hands(hands, where);
  }

  // Milliseconds the last call's poses took to compute (a memo hit still reports its full cost).
  double pose_ms() const;
  int64_t computed() const;  // poses computed, over the hands
  int64_t reused() const;    // poses answered from a hand's previous one
  // The state of hand `side` after the last call; null when that frame lacked it.
  const AvatarState* state(Handedness side) const;

 private:
  const PosedGaussians& pose_hands(const std::array<const HandParams*, 2>& hands, const std::string& where);

  bool two_hands_ = false;
  Handedness first_ = Handedness::right;
  HandParams one_;  // a one-hand frame's pose, copied
  std::array<std::unique_ptr<PoseMemo>, 2> memos_;  // by Handedness; null for a hand not trained
  std::array<bool, 2> posed_{};                   // in the last call
  PosedGaussians joined_;
  double pose_ms_ = 0;
};

}  // namespace handscs
