// Hands from a 2D hand detector's output in several calibrated views: which detections show the
// same hand (a detector's left/right label is not trusted: MediaPipe's assumes a mirrored selfie
// image and mislabels hands in some views), then each joint triangulated robustly over them.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "core/camera.h"
#include "hand/keypoint_fit.h"

namespace handscs {

// One detected hand in one view, its landmarks already in MANO21 order (pixels, the project's
// pixel-centre convention).
struct Detection {
  int view = 0;
  std::string label;  // what the detector called it ("Left", "Right", or "")
  std::array<std::array<double, 2>, 21> pixels{};
  std::array<uint8_t, 21> valid{};
};

struct MultiviewConfig {
  // A landmark farther than this from the reprojected point is an outlier (px). MediaPipe's
  // landmarks on a hand ~200 px long scatter by ~5-15 px between views; a mislabelled finger or a
  // detection of the other hand lands 50 px or more away.
  double inlier_px = 30.0;
  int max_hands = 2;  // hands looked for (a capture of one or both hands)
  int min_views = 2;  // detections a hand needs (two views fix a point)

  template <class V>
  void visit(V& v) {
    v.field("inlier_px", inlier_px, "landmark distance (px) beyond which a view is dropped", 0.1, 1e5);
    v.field("max_hands", max_hands, "hands looked for", 1, 2);
    v.field("min_views", min_views, "detections a hand needs", 2, 1000);
  }
};

struct TriangulatedHand {
  std::vector<int> detections;          // indices into the detections given (one per view at most)
  HandKeypoints keypoints;              // MANO21, world frame (metres)
  std::array<std::vector<int>, 21> used_views, dropped_views;  // per joint: views kept / dropped
  std::vector<int> dropped_joints;      // joints no two views agree on
  // Detections that agreed with each other but not with this hand's, lying where it does: this hand
  // seen again in views whose landmarks missed inlier_px. Left out of every hand.
  std::vector<int> repeated_detections;
};

// Groups the detections into at most max_hands hands, most supported first, and triangulates each.
// A group that lies where an earlier hand does, in views where that hand was not seen, is that
// hand again, not a second one (TriangulatedHand::repeated_detections).
std::vector<TriangulatedHand> find_hands(const std::vector<Camera>& cameras,
                                         const std::vector<Detection>& detections,
                                         const MultiviewConfig& config);

// Median over valid joints of the distance (px) between a detection's landmarks and the
// projection of MANO21 joints [63]; infinity when no joint is shared.
double median_reprojection_px(const Camera& camera, const Detection& detection, const double* joints,
                              const std::array<uint8_t, 21>& joints_valid);

}  // namespace handscs
