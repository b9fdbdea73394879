// What handscs-view shows: a trained avatar, the held-out poses of its run's capture, and frames
// rendered on request by the path handscs-render takes (infer/avatar_render.cpp: the pose decoded
// once through PoseMemo, rasterised with render_posed, the avatar's own colours on a black
// background, 8-bit RGB), encoded as JPEG or PNG. One frame renders at a time (the avatar and its
// memo are not thread-safe); callers on other threads wait.
#pragma once

#include <mutex>
#include <string>
#include <vector>

#include "avatar/pose_memo.h"
#include "infer/pose_source.h"
#include "infer/posed_hands.h"
#include "run/avatar_state_io.h"
#include "synth/hand_axes.h"
#include "view/view_request.h"

namespace handscs {

struct ViewFrame {
  std::string bytes;         // encoded image
  std::string content_type;  // "image/jpeg" or "image/png"
  double frame_ms = 0;       // this request's posing (none when the pose is the previous one's),
                             // rasterisation and encoding
  int64_t gaussians = 0;
};

class ViewScene {
 public:
  // held_out: the poses the page steps through (may be empty).
  ViewScene(TrainedAvatar trained, std::vector<PoseFrame> held_out);

  // Opens a checkpoint file or run folder and its capture's held-out poses (one per pose, first
  // camera's annotation); a capture that cannot be opened leaves the list empty, with a warning.
  // With `poses` (a POSES or keypoint file, infer/pose_source.h) the page steps through its poses
  // instead.
  static ViewScene open(const std::string& checkpoint, const std::string& poses = "");

  // The page's start-up data: Gaussian count, controls, gestures, held-out pose names, default view.
  json info() const;
  const OrbitView& default_view() const { return default_view_; }

  // The request's pose as a POSES entry (held-out index checked: Error when out of range).
  PoseFrame pose_of(const ViewRequest& request) const;
  // The camera the request's view makes around its posed hand.
  Camera camera_of(const ViewRequest& request);
  ViewFrame render(const ViewRequest& request);

 private:
  // The frame's hands posed and joined (under mutex_); camera_for() then orbits them.
  const PosedGaussians& posed(const PoseFrame& frame);
  // The camera around the hands posed last: about the mean of their centres, turned with the
  // first hand's root.
  Camera camera_for(const OrbitView& view) const;

  TrainedAvatar trained_;
  std::vector<PoseFrame> held_out_;
  HandAxes axes_;
  PoseFrame base_;  // shape and trans of control poses: the first held-out pose's (the capture's hand)
  std::array<std::array<double, 3>, 2> rest_centres_{};  // each hand's mean canonical Gaussian centre
                                                        // (rest space), by Handedness
  OrbitView default_view_;
  int64_t gaussians_ = 0;
  std::mutex mutex_;
  PosedHands hands_;
};

}  // namespace handscs
