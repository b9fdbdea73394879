// Region masks: where an image has structural effects (creases, contact, cast shadows...), as an
// 8-bit PNG per image whose bit b marks region b, and the legend regions.json naming the bits:
//   {"regions": [{"name": "crease", "bit": 1, "description": "..."}, ...]}  (other keys ignored).
// A capture keeps them beside images/: regions/<split>/<image path with .png>, regions/regions.json.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <torch/types.h>

namespace handscs {

// The legend's file name inside a regions folder.
inline constexpr const char* kRegionLegendFile = "regions.json";

struct RegionSpec {
  std::string name;         // letters, digits, '_' or '-' (it names CSV columns)
  int bit = 0;              // its bit value in the mask: 1, 2, 4, ..., 128
  std::string description;  // optional
};

struct RegionLegend {
  std::string path;                // the regions.json it came from
  std::vector<RegionSpec> regions;  // in file order; names and bits unique

  bool empty() const { return regions.empty(); }
};

// Reads and checks a legend. Errors name the file and the key, e.g.
// "DIR/regions.json: regions[1].bit: expected one of 1, 2, 4, 8, 16, 32, 64, 128, got 3".
RegionLegend read_region_legend(const std::string& path);

// Where the mask of an image lives: <regions_dir>/<relative image path, extension .png>.
std::string region_mask_path(const std::string& regions_dir, const std::string& relative_image_path);

// Reads a mask file: single-channel 8-bit, `width` x `height`; [H, W] uint8. Errors name the file:
// "<path>: region mask not found", "... cannot read region mask", "... region mask must be a
// single-channel 8-bit image (got 3 channels, 16-bit)", "... region mask is 20x16 but the image is
// 24x16 (width x height)".
torch::Tensor load_region_mask(const std::string& path, int64_t width, int64_t height);

// [R, H, W] bool, one plane per legend region: bits & region.bit (bits the legend does not name
// are ignored).
torch::Tensor region_planes(const torch::Tensor& bits,  // [H, W] uint8
                            const RegionLegend& legend);

}  // namespace handscs
