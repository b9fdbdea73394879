// Plausibility of a pinhole camera beyond what parses: an image size the machine can hold, a
// field of view a lens can have, a principal point near the image. A camera outside these renders
// black or absurd images without any error, so readers check every camera they build.
#pragma once

#include <string>

#include "core/camera.h"

namespace handscs {

// Largest image a camera may have, in pixels: 100 megapixels (10x the 4K frames of capture rigs).
// Rendering keeps ~20 bytes per pixel (RGB, alpha, depth, tile lists), ~2 GB at this size.
constexpr double kMaxCameraPixels = 1e8;
// Focal lengths as multiples of the image side: 0.04 is a 170-degree field of view, 120 a
// 0.5-degree one; lenses of hand captures (InterHand2.6M: ~40-80 degrees) sit far inside.
constexpr double kMinFocalPerSide = 0.04;
constexpr double kMaxFocalPerSide = 120.0;
// The principal point may lie at most this many image sides outside the image (cropped or
// off-centre sensors keep it inside; beyond this the image shows a sliver of the frustum).
constexpr double kMaxPrincipalOffsetSides = 1.0;

// "" when plausible, else the problem, e.g. "fx = 1e-30 is 1e-33 image widths: outside the
// plausible 0.04-120 (fields of view of 170 to 0.5 degrees)". Width and height must be positive.
std::string camera_intrinsics_problem(const Camera& camera);

// "" when K (row-major 3x3) has the pinhole form [fx 0 cx; 0 fy cy; 0 0 1] with positive focal
// lengths (core/camera.h has no skew), else what is wrong.
std::string pinhole_matrix_problem(const std::array<double, 9>& K);

// Largest |R R^T - I| entry accepted for a rotation: annotation files store 6-8 digits.
constexpr double kRotationTolerance = 1e-4;

// "" when R (row-major 3x3) is a rotation (R R^T = I within kRotationTolerance, det +1), else
// "not a rotation matrix (R R^T != I or det < 0)".
std::string rotation_problem(const std::array<double, 9>& R);

}  // namespace handscs
