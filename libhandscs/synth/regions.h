// Region masks of a realistic capture: one 8-bit PNG per image under regions/ beside images/
// (regions/<split>/Capture<c>/<seq>/cam<id>/image<frame>.png), bit k set where the pixel centre
// sees a structural effect, then dilated by one pixel (so a region survives sub-pixel misalignment);
// regions/regions.json is the legend handscs-eval reads.
#pragma once

#include <cstdint>
#include <string>

namespace handscs {

enum RegionBit : uint8_t {
  kRegionCrease = 1,   // creases (static or flexed footprint) or blanched knuckles > kCreaseThreshold
  kRegionContact = 2,  // tissue flattened by contact, or folds/touching fingers (occlusion)
  kRegionShadow = 4,   // a lit surface in the key light's cast shadow
};

// A crease darkens (or a knuckle lightens) by at least 2%: ~4 levels on skin, above JPEG noise.
constexpr double kCreaseThreshold = 0.02;
// Contact: flattened by at least 0.2 mm (a quarter pixel at 1 m), or ambient occlusion of 0.35.
constexpr double kContactThreshold = 2e-4, kOcclusionThreshold = 0.35;
// Shadow: less than 95% of the key light reaches a surface that faces it (cos > 0.05): a shadow of
// 5% of the key light changes a lit pixel by at most ~8 levels.
constexpr double kShadowThreshold = 0.95, kFacingThreshold = 0.05;

// The legend written to regions/regions.json.
std::string regions_legend_json();

}  // namespace handscs
