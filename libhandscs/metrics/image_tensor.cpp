#include "metrics/image_tensor.h"

#include <cstring>
#include <filesystem>
#include <vector>

#include <ATen/ATen.h>
#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "core/jpeg_damage.h"
#include "core/png_damage.h"
#include "io/image_file.h"

namespace handscs {

namespace {

// Scale that maps the depth's full range to [0, 1].
double depth_scale(int depth) {
  switch (depth) {
    case CV_8U: return 1.0 / 255.0;
    case CV_16U: return 1.0 / 65535.0;
    case CV_32F: return 1.0;
    case CV_64F: return 1.0;
    default:
      throw Error("unsupported image depth (need 8-bit, 16-bit or float; got OpenCV depth " +
                  std::to_string(depth) + ")");
  }
}

// [H, W, C] float32 tensor holding a copy of `image` scaled to [0, 1] (channel order unchanged).
torch::Tensor to_float_tensor(const cv::Mat& image) {
  cv::Mat converted;
  image.convertTo(converted, CV_32F, depth_scale(image.depth()));
  return torch::from_blob(converted.data, {converted.rows, converted.cols, converted.channels()},
                          torch::kFloat)
      .clone();
}

}  // namespace

torch::Tensor mat_to_rgb_tensor(const cv::Mat& image, const std::array<double, 3>& background) {
  require(!image.empty(), "empty image");
  const int channels = image.channels();
  require(channels == 1 || channels == 3 || channels == 4,
          "unsupported channel count " + std::to_string(channels) + " (need 1, 3 or 4)");
  const auto values = to_float_tensor(image);
  if (channels == 1) return values.expand({-1, -1, 3}).contiguous();
  const auto rgb = values.narrow(2, 0, 3).flip({2});  // BGR -> RGB
  if (channels == 3) return rgb.contiguous();
  const auto alpha = values.narrow(2, 3, 1);
  const auto bg = torch::tensor({background[0], background[1], background[2]}, torch::kDouble)
                      .to(torch::kFloat)
                      .view({1, 1, 3});
  return (rgb * alpha + bg * (1 - alpha)).contiguous();
}

torch::Tensor mat_to_mask_tensor(const cv::Mat& mask) {
  require(!mask.empty(), "empty mask");
  const auto values = to_float_tensor(mask);
  const int channels = mask.channels();
  if (channels == 1) return values.select(2, 0).contiguous();
  require(channels == 3 || channels == 4,
          "unsupported mask channel count " + std::to_string(channels) + " (need 1, 3 or 4)");
  const auto first = values.select(2, 0);
  require(at::equal(first, values.select(2, 1)) && at::equal(first, values.select(2, 2)),
          "mask has colour (its channels differ); give a gray mask");
  return first.contiguous();
}

cv::Mat rgb_tensor_to_mat(const torch::Tensor& rgb) {
  TORCH_CHECK(rgb.dim() == 3 && rgb.size(2) == 3, "rgb_tensor_to_mat: expected [H, W, 3], got ",
              rgb.sizes());
  const auto bgr = (rgb.detach().to(torch::kFloat).clamp(0, 1) * 255.0)
                       .round()
                       .to(torch::kUInt8)
                       .flip({2})
                       .contiguous();
  cv::Mat image(static_cast<int>(rgb.size(0)), static_cast<int>(rgb.size(1)), CV_8UC3);
  std::memcpy(image.data, bgr.data_ptr<uint8_t>(), bgr.numel());
  return image;
}

namespace {
// The file decoded as stored (cv::IMREAD_UNCHANGED), after a damage check of JPEGs and PNGs: a
// damaged JPEG would decode with a grey tail and be scored as if whole, and a damaged PNG would
// make libpng print its own error without the path. `what` names the file's role.
cv::Mat decode_checked(const std::string& path, const std::string& what) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec))
    throw Error(path + ": cannot read " + what +
                (ec && ec != std::errc::no_such_file_or_directory ? " (" + ec.message() + ")" : ""));
  std::string problem;
  const std::string bytes = read_image_file(path, problem);
  if (!problem.empty()) throw Error(path + ": damaged JPEG " + what + " (" + problem + ")");
  if (is_png_data(bytes))
    if (const std::string damage = png_damage(bytes); !damage.empty())
      throw Error(path + ": damaged PNG " + what + " (" + damage + ")");
  const cv::Mat image = decode_image_bytes(bytes, cv::IMREAD_UNCHANGED, path, what);
  if (image.empty()) throw Error(path + ": cannot read " + what);
  return image;
}

// One channel, or colour channels (alpha aside) equal at every pixel: a grey picture stored as RGB.
bool holds_grey(const cv::Mat& image) {
  if (image.channels() == 1) return true;
  // NaN compares unequal to nothing: such an image is reported as non-finite, not as grey.
  if (image.depth() >= CV_32F && !cv::checkRange(image)) return false;
  std::vector<cv::Mat> planes;
  cv::split(image, planes);
  for (int c = 1; c < 3; ++c)
    if (cv::countNonZero(planes[0] != planes[c]) > 0) return false;
  return true;
}
}  // namespace

torch::Tensor load_rgb_image(const std::string& path, const std::array<double, 3>& background, bool* is_grey) {
  const cv::Mat image = decode_checked(path, "image");
  if (is_grey) *is_grey = holds_grey(image);
  try {
    return mat_to_rgb_tensor(image, background);
  } catch (const Error& e) {
    throw Error(path + ": " + e.what());
  }
}

torch::Tensor load_mask_image(const std::string& path) {
  const cv::Mat mask = decode_checked(path, "mask");
  try {
    return mat_to_mask_tensor(mask);
  } catch (const Error& e) {
    throw Error(path + ": " + e.what());
  }
}

torch::Tensor hwc_to_bchw(const torch::Tensor& image) {
  TORCH_CHECK(image.dim() == 3 || image.dim() == 4, "hwc_to_bchw: expected [H, W, C] or [B, H, W, C], got ",
              image.sizes());
  const auto batched = image.dim() == 3 ? image.unsqueeze(0) : image;
  return batched.permute({0, 3, 1, 2}).contiguous();
}

torch::Tensor bchw_to_hwc(const torch::Tensor& images) {
  TORCH_CHECK(images.dim() == 4, "bchw_to_hwc: expected [B, C, H, W], got ", images.sizes());
  const auto hwc = images.permute({0, 2, 3, 1}).contiguous();
  return images.size(0) == 1 ? hwc.squeeze(0) : hwc;
}

}  // namespace handscs
