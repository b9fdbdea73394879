#include "data/lens_distortion.h"

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
