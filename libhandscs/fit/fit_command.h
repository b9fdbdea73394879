// handscs-fit: the rig fitted to 3D keypoints (a keypoint file or InterHand2.6M's joint_3d.json)
// or to multi-view 2D landmarks (triangulated robustly first), for each hand; writes POSES files
// for handscs-render and handscs-view, a report of the residuals, and a capture.json: for a multi-view
// capture (with pictures of the fitted meshes over the photographs), or for a keypoint file with
// the capture its frames belong to (--capture-dir). docs/FIT.md.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "fit/multiview_hands.h"
#include "hand/keypoint_fit.h"

namespace handscs {

struct FitCommandConfig {
  KeypointFitConfig fit;
  MultiviewConfig multiview;
  // A hand whose mean residual exceeds this is skipped as a poor fit (mm). Keypoints of a real
  // hand fit the built-in hand to ~3-5 mm (docs/FIT.md); 15 mm is a finger's width off: mislabelled
  // joints, another person's hand or a wrong order, never a usable pose.
  double poor_fit_mm = 15.0;

  template <class V>
  void visit(V& v) {
    v.section("fit", fit, "the rig fitted to 3D keypoints");
    v.section("multiview", multiview, "triangulation of multi-view landmarks");
    v.field("poor_fit_mm", poor_fit_mm, "skip a hand whose mean residual (mm) exceeds this", 0.1, 1e6);
  }
};

struct FitCommandOptions {
  std::string keypoints;         // a keypoint file (fit/keypoint_file.h)
  std::string interhand_joints;  // InterHand2.6M joint_3d.json, with capture
  int capture = -1;
  std::string multiview;         // a multi-view capture folder (fit/multiview_capture.h)
  std::string capture_dir;       // with keypoints: the capture whose hands they give (fit/fitted_capture.h)
  std::string out;               // output folder
  bool overwrite = false;
  std::string config;                  // a JSON file of FitCommandConfig
  std::vector<std::string> overrides;  // --set key=value
  std::string rig_right = "builtin", rig_left = "builtin:left";
  bool flat_hand_mean = false;   // write poses absolute instead of relative to hands_mean
  std::vector<int> overlay_views;  // multi-view: views to draw the fit over (default: 4 spread)
  int64_t overlay_frame = -1;      // multi-view sequence: the instant drawn (-1: the first fitted)
};

void run_fit_command(const FitCommandOptions& options);

}  // namespace handscs
