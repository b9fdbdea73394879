// Turntable cameras around a posed hand: `count` views evenly spaced on a circle around the hand's
// long axis (wrist -> middle fingertip), each looking at the hand's centre with the fingers up.
#pragma once

#include <array>
#include <vector>

#include "core/camera.h"

namespace handscs {

struct OrbitSpec {
  int count = 60;
  int width = 512;       // InterHand2.6M image size
  int height = 334;
  double focal = 1200;   // px, InterHand-like for 512x334
  double fill = 0.7;     // fraction of the image height the hand's extent spans
  double elevation = 0.35;  // rad above the plane perpendicular to the long axis (~20 degrees)
};

// centre: point looked at; axis: the hand's long axis (unit or not); extent: hand size (m).
std::vector<Camera> orbit_cameras(const std::array<double, 3>& centre, const std::array<double, 3>& axis,
                                  double extent, const OrbitSpec& spec);

}  // namespace handscs
