// One view of the synthetic hand, rendered with the z-buffer mesh rasteriser (data/mesh_raster.h):
// s x s sub-samples per pixel with barycentric interpolation of normal n, canonical point p, nail
// and palmar weights and fold occlusion o; colour = albedo(p) (ambient + sum_k L_k max(0, n . l_k))
// (1 - 0.55 o), box-filtered to pixels, over a dark background with slight per-pixel noise.
#pragma once

#include <cstdint>
#include <opencv2/core/mat.hpp>
#include <vector>

#include "core/camera.h"
#include "data/synth_skin.h"

namespace handscs {

// A posed mesh with the per-vertex attributes the shading needs (world metres).
struct SynthMeshView {
  const std::vector<float>* vertices;   // [V * 3]
  const std::vector<float>* normals;    // [V * 3] unit
  const std::vector<float>* occlusion;  // [V]
  const std::vector<int64_t>* faces;    // [F * 3]
};

struct SynthView {
  cv::Mat bgr;       // CV_8UC3 rendered image
  cv::Mat coverage;  // CV_8UC1 1 where the centre sub-sample, i.e. the pixel centre, hits the hand
  cv::Mat samples;   // CV_8UC1 number of the s*s sub-samples that hit the hand
};

// supersample: odd s >= 1; noise_seed: background noise stream (deterministic per image).
SynthView render_synth_view(const SynthSkin& skin, const SynthMeshView& mesh, const Camera& camera,
                            int supersample, uint64_t noise_seed);

}  // namespace handscs
