// Lens distortion in OpenCV's model (k1 k2 p1 p2 k3: radial and tangential) and its removal: an
// image is undistorted to the same size and the same K (initUndistortRectifyMap with newK = K), so
// the rasterizers keep their pinhole camera. Pixels whose source lies outside the recorded image
// become black. K is given in core/camera.h's convention (pixel (i, j) centred at (i+.5, j+.5));
// OpenCV centres pixels on integers, so its K has cx, cy half a pixel smaller.
#pragma once

#include <array>
#include <string>
#include <opencv2/core/mat.hpp>

#include "core/camera.h"

namespace handscs {

// core/camera.h centres pixel i at i + 0.5, OpenCV at i: OpenCV's cx, cy are this much smaller.
constexpr double kOpenCvPixelOffset = 0.5;

struct LensDistortion {
  std::array<double, 5> coefficients{};  // k1, k2, p1, p2, k3 (OpenCV's order)
  bool any() const {
    for (double c : coefficients)
      if (c != 0) return true;
    return false;
  }
};

// cv::remap maps that undistort an image of `camera` (its width x height).
struct UndistortMaps {
  cv::Mat map_x, map_y;  // CV_32FC1
};
UndistortMaps undistort_maps(const Camera& camera, const LensDistortion& distortion);

// "" when the distortion is a lens's: its radial mapping keeps increasing out to the image's
// corners, and `maps` (undistort_maps of it) take at least half of the undistorted image from
// inside the recorded one. Otherwise what is wrong, in words: a mapping that turns back would
// mirror part of the image, one that leaves the image would turn it black.
std::string distortion_problem(const Camera& camera, const LensDistortion& distortion,
                               const UndistortMaps& maps);

// The image an ideal pinhole camera with `camera`'s K would have recorded (bilinear).
cv::Mat undistort_image(const cv::Mat& image, const UndistortMaps& maps);

// The inverse, for synthetic captures: a pinhole image of `camera` as a lens with `distortion`
// records it (bilinear; borders replicated), so that undistort_image recovers it up to resampling.
cv::Mat distort_image(const cv::Mat& pinhole, const Camera& camera,
                      const LensDistortion& distortion);

// K in OpenCV's pixel-centre convention (cx, cy minus half a pixel).
cv::Mat opencv_intrinsics(const Camera& camera);

}  // namespace handscs
