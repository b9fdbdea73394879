#include "io/png.h"

#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <vector>

#include <torch/types.h>

#include "core/atomic_file.h"
#include "core/error.h"

namespace handscs {

void write_png(const std::string& path, const cv::Mat& image) {
  std::vector<uchar> bytes;
  if (!cv::imencode(".png", image, bytes)) throw Error(path + ": PNG encoding failed");
  const auto parent = std::filesystem::path(path).parent_path();
  if (!parent.empty()) ensure_directory(parent.string());
  write_file_atomic(path, std::string(bytes.begin(), bytes.end()));
}

void write_png(const std::string& path, const torch::Tensor& image) {
  require(image.dim() == 2 || (image.dim() == 3 && image.size(2) == 3),
          path + ": a PNG is written from [H, W] or [H, W, 3] images");
  auto bytes = (image.detach().to(torch::kFloat32).clamp(0, 1) * 255).round().to(torch::kUInt8).contiguous();
  const int h = static_cast<int>(image.size(0)), w = static_cast<int>(image.size(1));
  cv::Mat mat;
  if (image.dim() == 3) {
    bytes = bytes.flip({2}).contiguous();  // RGB -> OpenCV's BGR
    mat = cv::Mat(h, w, CV_8UC3, bytes.data_ptr<uint8_t>());
  } else {
    mat = cv::Mat(h, w, CV_8UC1, bytes.data_ptr<uint8_t>());
  }
  write_png(path, mat);
}

}  // namespace handscs
