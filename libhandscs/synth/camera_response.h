// What a real camera does to the light reaching it: an exposure gain and white balance per camera,
// lens vignetting (1 - k r^2, r the distance from the image centre over the half-diagonal), sensor
// noise with variance read^2 + shot * signal (levels), and monochrome sensors (Rec. 601 luma,
// one noise sample for all three channels).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "synth/effects.h"

namespace handscs {

struct CameraResponse {
  double gain = 1;
  double white_balance[3] = {1, 1, 1};  // R, G, B multipliers
  double vignetting = 0;                // k
  bool monochrome = false;
};

// One response per camera, deterministic from the seed.
std::vector<CameraResponse> make_camera_responses(const SynthEffects& effects, int num_cameras,
                                                  uint64_t seed);

// radiance: CV_32FC3 BGR in 8-bit levels -> CV_8UC3 image; noise from `noise_seed`.
cv::Mat expose(const cv::Mat& radiance, const CameraResponse& response,
               const SynthEffects& effects, uint64_t noise_seed);

}  // namespace handscs
