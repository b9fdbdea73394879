// A fitted hand mesh drawn over a photograph, to judge a fit by eye: every face filled with a
// flat-shaded colour at half opacity, far faces first, and the fitted joints as dots, cropped to
// the hands.
#pragma once

#include <array>
#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "core/camera.h"
#include "hand/rig.h"

namespace handscs {

struct OverlayHand {
  const Rig* rig = nullptr;
  torch::Tensor vertices;             // [V, 3] posed, world frame
  std::array<double, 63> joints{};    // MANO21, world frame
  cv::Scalar colour;                  // BGR
};

// The photograph (BGR) with the hands drawn in, cropped to their projection plus `margin_px`.
cv::Mat draw_overlay(const cv::Mat& photo, const Camera& camera, const std::vector<OverlayHand>& hands,
                     int margin_px);

}  // namespace handscs
