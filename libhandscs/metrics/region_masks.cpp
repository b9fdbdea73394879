#include "metrics/region_masks.h"

#include <cctype>
#include <filesystem>

#include <ATen/ATen.h>

#include "core/config.h"
#include "core/error.h"
#include "io/image_file.h"

namespace handscs {

namespace {

bool valid_name(const std::string& name) {
  if (name.empty()) return false;
  for (unsigned char c : name)
    if (!std::isalnum(c) && c != '_' && c != '-') return false;
  return true;
}

std::string depth_text(int depth) {
  switch (depth) {
    case CV_8U: return "8-bit";
    case CV_8S: return "signed 8-bit";
    case CV_16U: return "16-bit";
    case CV_16S: return "signed 16-bit";
    case CV_32S: return "32-bit integer";
    case CV_32F: return "32-bit float";
    case CV_64F: return "64-bit float";
    default: return "OpenCV depth " + std::to_string(depth);
  }
}

}  // namespace

RegionLegend read_region_legend(const std::string& path) {
  std::error_code ec;
  require(std::filesystem::is_regular_file(path, ec), path + ": region legend not found");
  const json file = load_json_file(path);
  const auto list = file.find("regions");
  require(list != file.end() && list->is_array(),
          path + ": regions: expected an array of {\"name\", \"bit\", \"description\"}");
  require(!list->empty(), path + ": regions: the legend names no region");
  RegionLegend legend;
  legend.path = path;
  for (size_t i = 0; i < list->size(); ++i) {
    const json& item = (*list)[i];
    const std::string key = path + ": regions[" + std::to_string(i) + "]";
    require(item.is_object(), key + ": expected an object with \"name\" and \"bit\", got " +
                                  json_type_name(item));
    RegionSpec spec;
    const auto name = item.find("name");
    require(name != item.end() && name->is_string() && valid_name(name->get<std::string>()),
            key + ".name: expected a non-empty string of letters, digits, '_' or '-'");
    spec.name = name->get<std::string>();
    const auto bit = item.find("bit");
    // One bit of the 8-bit mask: a region is a bit plane, so two regions can overlap.
    const bool one_bit = bit != item.end() && bit->is_number_integer() && bit->get<int64_t>() > 0 &&
                         bit->get<int64_t>() <= 128 && (bit->get<int64_t>() & (bit->get<int64_t>() - 1)) == 0;
    require(one_bit, key + ".bit: expected one of 1, 2, 4, 8, 16, 32, 64, 128, got " +
                         (bit == item.end() ? std::string("nothing") : bit->dump()));
    spec.bit = bit->get<int>();
    const auto description = item.find("description");
    if (description != item.end()) {
      require(description->is_string(), key + ".description: expected a string, got " +
                                            json_type_name(*description));
      spec.description = description->get<std::string>();
    }
    for (const auto& other : legend.regions) {
      require(other.name != spec.name, key + ".name: \"" + spec.name + "\" is listed twice");
      require(other.bit != spec.bit, key + ".bit: " + std::to_string(spec.bit) +
                                         " is already the bit of \"" + other.name + "\"");
    }
    legend.regions.push_back(std::move(spec));
  }
  return legend;
}

std::string region_mask_path(const std::string& regions_dir, const std::string& relative_image_path) {
  return (std::filesystem::path(regions_dir) / relative_image_path).replace_extension(".png").string();
}

torch::Tensor load_region_mask(const std::string& path, int64_t width, int64_t height) {
  std::error_code ec;
  require(std::filesystem::is_regular_file(path, ec), path + ": region mask not found");
  const cv::Mat mask = decode_image_file(path, cv::IMREAD_UNCHANGED, "region mask");
  require(!mask.empty(), path + ": cannot read region mask");
  require(mask.depth() == CV_8U && mask.channels() == 1,
          path + ": region mask must be a single-channel 8-bit image (got " +
              std::to_string(mask.channels()) + (mask.channels() == 1 ? " channel, " : " channels, ") +
              depth_text(mask.depth()) + ")");
  require(mask.cols == width && mask.rows == height,
          path + ": region mask is " + std::to_string(mask.cols) + "x" + std::to_string(mask.rows) +
              " but the image is " + std::to_string(width) + "x" + std::to_string(height) +
              " (width x height)");
  const cv::Mat packed = mask.isContinuous() ? mask : mask.clone();
  return torch::from_blob(packed.data, {height, width}, torch::kUInt8).clone();
}

torch::Tensor region_planes(const torch::Tensor& bits, const RegionLegend& legend) {
  TORCH_CHECK(bits.dim() == 2 && bits.scalar_type() == torch::kUInt8,
              "region_planes: expected [H, W] uint8 bits, got ", bits.sizes(), " ", bits.scalar_type());
  std::vector<torch::Tensor> planes;
  for (const auto& region : legend.regions) planes.push_back(at::bitwise_and(bits, region.bit).ne(0));
  return at::stack(planes, 0);
}

}  // namespace handscs
