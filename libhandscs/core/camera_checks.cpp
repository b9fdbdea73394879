#include "core/camera_checks.h"

#include <algorithm>
#include <cmath>

#include "core/text.h"

namespace handscs {
namespace {

std::string focal_problem(const char* name, double focal, int side, const char* side_name) {
  const double per_side = focal / side;
  if (per_side >= kMinFocalPerSide && per_side <= kMaxFocalPerSide) return "";
  return std::string(name) + " = " + number_text(focal) + " is " + number_text(per_side) + " image " +
         side_name + "s: outside the plausible " + number_text(kMinFocalPerSide) + "-" +
         number_text(kMaxFocalPerSide) + " (fields of view of 170 to 0.5 degrees)";
}

std::string principal_problem(const char* name, double centre, int side, const char* side_name) {
  const double margin = kMaxPrincipalOffsetSides * side;
  if (centre >= -margin && centre <= side + margin) return "";
  return std::string(name) + " = " + number_text(centre) + " lies more than " +
         number_text(kMaxPrincipalOffsetSides) + " image " + side_name + " outside the image (0-" +
         std::to_string(side) + ")";
}

}  // namespace

std::string pinhole_matrix_problem(const std::array<double, 9>& K) {
  if (K[1] != 0 || K[3] != 0 || K[6] != 0 || K[7] != 0 || K[8] != 1)
    return "expected [[fx, 0, cx], [0, fy, cy], [0, 0, 1]] (the rasterizer's pinhole has no skew)";
  if (!(K[0] > 0 && K[4] > 0)) return "focal lengths must be positive";
  return "";
}

std::string rotation_problem(const std::array<double, 9>& R) {
  double worst = 0;
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) {
      double dot = 0;
      for (int k = 0; k < 3; ++k) dot += R[3 * a + k] * R[3 * b + k];
      worst = std::max(worst, std::abs(dot - (a == b ? 1.0 : 0.0)));
    }
  const double det = R[0] * (R[4] * R[8] - R[5] * R[7]) - R[1] * (R[3] * R[8] - R[5] * R[6]) +
                     R[2] * (R[3] * R[7] - R[4] * R[6]);
  if (!(worst <= kRotationTolerance) || det < 0) return "not a rotation matrix (R R^T != I or det < 0)";
  return "";
}

std::string camera_intrinsics_problem(const Camera& camera) {
  const double pixels = static_cast<double>(camera.width) * camera.height;
  if (pixels > kMaxCameraPixels)
    return "image of " + std::to_string(camera.width) + "x" + std::to_string(camera.height) + " = " +
           number_text(pixels / 1e6) + " megapixels exceeds the " + number_text(kMaxCameraPixels / 1e6) +
           " megapixel limit";
  for (const std::string& problem :
       {focal_problem("fx", camera.fx(), camera.width, "width"),
        focal_problem("fy", camera.fy(), camera.height, "height"),
        principal_problem("cx", camera.cx(), camera.width, "width"),
        principal_problem("cy", camera.cy(), camera.height, "height")})
    if (!problem.empty()) return problem;
  return "";
}

}  // namespace handscs
