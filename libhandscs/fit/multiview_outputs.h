// What handscs-fit --multiview writes beside the POSES files and the report: a capture.json of the
// fitted instants with the images and masks linked (a `handscs` capture of its own, or the neus
// layout's hands file), the capture's masks as the region "hands", the reprojection of the
// triangulated and the fitted joints against every view's landmarks, and the fitted meshes drawn
// over the photographs of one instant (docs/FIT.md).
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "data/capture_config.h"
#include "fit/multiview_capture.h"
#include "fit/multiview_hands.h"
#include "hand/joint_model.h"
#include "hand/keypoint_fit.h"
#include "hand/rig.h"

namespace handscs {

// The fit's two hands by index: 0 right, 1 left (named by hand_name, data/capture_config.h).
constexpr Handedness kFitSides[2] = {Handedness::right, Handedness::left};

// One instant's hands as the fit left them.
struct MultiviewInstantFit {
  std::vector<TriangulatedHand> hands;      // what find_hands made of the instant's detections
  std::array<int, 2> side_of_hand{-1, -1};  // right, left: index into hands, -1 when not seen
  std::array<const HandFit*, 2> fits{};     // right, left: nullptr when not fitted
};

struct MultiviewOutputOptions {
  std::string out;               // the folder written into
  bool flat_hand_mean = false;   // poses absolute instead of relative to hands_mean
  std::vector<int> overlay_views;  // views to draw the fit over (default: 4 spread)
  int64_t overlay_frame = -1;    // the instant drawn (-1: the first with a fitted hand)
};

// `fits` holds one entry per instant of `cap`, in its order. Throws Error naming the file for an
// image or mask that cannot be read, and for an overlay_frame that has no fitted hand.
void write_multiview_outputs(const MultiviewOutputOptions& options, const MultiviewCapture& cap,
                             const std::vector<MultiviewInstantFit>& fits, const std::array<Rig, 2>& rigs,
                             const std::array<JointModel, 2>& models);

}  // namespace handscs
