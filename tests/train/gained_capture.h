// Test fixture for the per-camera colour transforms (train.camera_color): a copy of the tiny
// capture in which each camera's images are multiplied by known per-channel gains (camera k, in the
// order of its sorted id, by gains[k] = {R, G, B}), re-encoded as JPEG at quality 100.
#pragma once

#include <algorithm>
#include <array>
#include <filesystem>
#include <set>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "tiny_capture.h"

namespace handscs_test {

// The camera id of an image path ".../cam<id>/image<frame>.jpg".
inline std::string camera_of_image(const std::filesystem::path& image) {
  const std::string folder = image.parent_path().filename().string();
  return folder.rfind("cam", 0) == 0 ? folder.substr(3) : std::string();
}

// The capture's camera ids, sorted (the order the trainer gives its transforms' rows).
inline std::vector<std::string> capture_camera_ids(const std::string& root) {
  std::set<std::string> ids;
  for (const auto& entry : std::filesystem::recursive_directory_iterator(root + "/images"))
    if (entry.path().extension() == ".jpg") ids.insert(camera_of_image(entry.path()));
  return {ids.begin(), ids.end()};
}

// A copy of the tiny capture under <temp>/handscs_<name>_<pid> with camera k's images scaled by
// gains[k] (RGB; values above 255 saturate, so gains <= 1 keep the relation exact up to rounding).
inline std::string gained_tiny_capture(const std::string& name,
                                       const std::vector<std::array<double, 3>>& gains) {
  const std::string root = fresh_dir(name);
  std::filesystem::copy(tiny_capture_dir(), root, std::filesystem::copy_options::recursive);
  const auto ids = capture_camera_ids(root);
  for (const auto& entry : std::filesystem::recursive_directory_iterator(root + "/images")) {
    if (entry.path().extension() != ".jpg") continue;
    const auto id = camera_of_image(entry.path());
    const size_t k = static_cast<size_t>(std::find(ids.begin(), ids.end(), id) - ids.begin());
    if (k >= gains.size()) continue;
    cv::Mat image = cv::imread(entry.path().string(), cv::IMREAD_COLOR);  // BGR
    image.convertTo(image, CV_32FC3);
    cv::multiply(image, cv::Scalar(gains[k][2], gains[k][1], gains[k][0]), image);
    image.convertTo(image, CV_8UC3);  // rounds and saturates
    cv::imwrite(entry.path().string(), image, {cv::IMWRITE_JPEG_QUALITY, 100});
  }
  return root;
}

}  // namespace handscs_test
