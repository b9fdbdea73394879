// Mask refinement against the image, as HandAvatar does for InterHand2.6M: keep mask pixels whose
// intensity (B + G + R) / 3 lies strictly inside (low, high), then only the largest 8-connected
// component. Removes mesh-fit errors that spill onto the dark background or bright sleeves.
#pragma once

#include <opencv2/core/mat.hpp>

namespace handscs {

struct MaskRefineConfig {
  bool enabled = true;            // refine at all
  int low = 10;                   // exclusive lower intensity bound (HandAvatar: 10)
  int high = 200;                 // exclusive upper intensity bound (HandAvatar: 200)
  bool largest_component = true;  // keep only the largest connected component

  template <class V>
  void visit(V& v) {
    v.field("enabled", enabled, "refine the rasterised mesh mask against the image");
    v.field("low", low, "keep pixels with intensity > low", 0, 255);
    v.field("high", high, "keep pixels with intensity < high", 1, 256);
    v.field("largest_component", largest_component, "keep only the largest connected component");
  }
};

// mask: CV_8UC1 0/1, refined in place; bgr: CV_8UC3 image of the same size (or CV_8UC1 grey).
void refine_mask(cv::Mat& mask, const cv::Mat& bgr, const MaskRefineConfig& config);

// Keeps only the largest 8-connected component of a 0/1 mask (in place; no-op on an empty mask).
void keep_largest_component(cv::Mat& mask);

}  // namespace handscs
