#include "data/lens_distortion.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

namespace handscs {

namespace {

cv::Mat coefficients_mat(const LensDistortion& distortion) {
  cv::Mat d(1, 5, CV_64F);
  for (int i = 0; i < 5; ++i) d.at<double>(0, i) = distortion.coefficients[i];
  return d;
}

}  // namespace

cv::Mat opencv_intrinsics(const Camera& camera) {
  cv::Mat K(3, 3, CV_64F);
  for (int i = 0; i < 9; ++i) K.at<double>(i / 3, i % 3) = camera.K[i];
  K.at<double>(0, 2) -= kOpenCvPixelOffset;
  K.at<double>(1, 2) -= kOpenCvPixelOffset;
  return K;
}

UndistortMaps undistort_maps(const Camera& camera, const LensDistortion& distortion) {
  const cv::Mat K = opencv_intrinsics(camera);
  UndistortMaps maps;
  cv::initUndistortRectifyMap(K, coefficients_mat(distortion), cv::Mat(), K,
                              cv::Size(camera.width, camera.height), CV_32FC1, maps.map_x,
                              maps.map_y);
  return maps;
}

std::string distortion_problem(const Camera& camera, const LensDistortion& distortion,
                               const UndistortMaps& maps) {
  const auto& d = distortion.coefficients;
  const double fx = camera.K[0], fy = camera.K[4], cx = camera.K[2], cy = camera.K[5];
  // The farthest corner from the principal point, in normalised image coordinates.
  double r_max = 0;
  for (const double x : {0.0, double(camera.width)})
    for (const double y : {0.0, double(camera.height)})
      r_max = std::max(r_max, std::hypot((x - cx) / fx, (y - cy) / fy));
  // d/dr of r (1 + k1 r^2 + k2 r^4 + k3 r^6), sampled finely enough to find a turn inside.
  constexpr int kSamples = 1000;
  for (int i = 1; i <= kSamples; ++i) {
    const double r = r_max * i / kSamples, r2 = r * r;
    const double slope = 1 + 3 * d[0] * r2 + 5 * d[1] * r2 * r2 + 7 * d[4] * r2 * r2 * r2;
    if (slope <= 0) {
      char text[256];
      std::snprintf(text, sizeof(text),
                    "its radial distortion turns back at r = %.3g (normalised), inside the image "
                    "(corners at r = %.3g): part of the image would appear mirrored",
                    r, r_max);
      return text;
    }
  }
  const cv::Mat inside_x = (maps.map_x >= 0) & (maps.map_x <= camera.width - 1);
  const cv::Mat inside_y = (maps.map_y >= 0) & (maps.map_y <= camera.height - 1);
  const double inside = cv::countNonZero(inside_x & inside_y) / double(maps.map_x.total());
  // A strong pincushion lens loses its corners; losing half the picture is no lens.
  constexpr double kMinInside = 0.5;
  if (inside < kMinInside) {
    char text[256];
    std::snprintf(text, sizeof(text),
                  "its distortion takes %.0f%% of the undistorted image from outside the recorded "
                  "one: the image would be mostly black",
                  100 * (1 - inside));
    return text;
  }
  return "";
}

cv::Mat undistort_image(const cv::Mat& image, const UndistortMaps& maps) {
  cv::Mat out;
  cv::remap(image, out, maps.map_x, maps.map_y, cv::INTER_LINEAR, cv::BORDER_CONSTANT,
            cv::Scalar::all(0));
  return out;
}

cv::Mat distort_image(const cv::Mat& pinhole, const Camera& camera,
                      const LensDistortion& distortion) {
  const cv::Mat K = opencv_intrinsics(camera);
  const int w = camera.width, h = camera.height;
  std::vector<cv::Point2d> distorted(static_cast<size_t>(w) * h), ideal;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) distorted[static_cast<size_t>(y) * w + x] = {double(x), double(y)};
  // OpenCV's default of 5 fixed-point iterations leaves ~1e-3 px at the corners of a mild lens;
  // 50 iterations or 1e-12 reach double precision for the synthetic captures' coefficients.
  cv::undistortPoints(distorted, ideal, K, coefficients_mat(distortion), cv::noArray(), K,
                      cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 50, 1e-12));
  cv::Mat map_x(h, w, CV_32FC1), map_y(h, w, CV_32FC1);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const cv::Point2d& p = ideal[static_cast<size_t>(y) * w + x];
      map_x.at<float>(y, x) = static_cast<float>(p.x);
      map_y.at<float>(y, x) = static_cast<float>(p.y);
    }
  cv::Mat out;
  cv::remap(pinhole, out, map_x, map_y, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  return out;
}

}  // namespace handscs
