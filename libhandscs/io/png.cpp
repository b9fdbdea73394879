#include "io/png.h"

#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <vector>

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

}  // namespace handscs
