// One view of the synthetic hand, rendered with the z-buffer mesh rasteriser (data/mesh_raster.h):
// s x s sub-samples per pixel with barycentric interpolation of normal n, texture point p, nail
// and palmar weights, fold occlusion o and key-light visibility v; colour = albedo(p) (ambient +
// v L_key max(0, n . l_key) + L_fill max(0, n . l_fill)) (1 - 0.55 o), box-filtered to pixels, over
// a dark background (with per-pixel noise in the easy captures; the camera response adds it in the
// realistic ones).
#pragma once

#include <cstdint>
#include <limits>
#include <opencv2/core/mat.hpp>
#include <vector>

#include "core/camera.h"
#include "synth/math.h"
#include "synth/skin.h"

namespace handscs {

// A posed mesh with the per-vertex attributes the shading needs (world metres). Optional arrays
// left null fall back to the hand's own (texture, nail, palmar: the skin's) or to no effect.
struct SynthMeshView {
  const std::vector<float>* vertices;   // [V * 3]
  const std::vector<float>* normals;    // [V * 3] unit
  const std::vector<float>* occlusion;  // [V]
  const std::vector<int64_t>* faces;    // [F * 3]
  const std::vector<float>* texture = nullptr;     // [V * 3] texture points (rest pose, m)
  const std::vector<float>* nail = nullptr;        // [V]
  const std::vector<float>* palmar = nullptr;      // [V]
  const std::vector<float>* visibility = nullptr;  // [V] key light visibility in [0, 1]
  const std::vector<float>* contact = nullptr;     // [V] contact flattening (m)
  const SkinFlexion* flexion = nullptr;            // flexion-dependent creases
  // A second hand (hand both): its faces, from second_hand_face on, crease by its own flexion.
  const SkinFlexion* second_flexion = nullptr;
  int64_t second_hand_face = std::numeric_limits<int64_t>::max();
};

struct SynthView {
  cv::Mat bgr;       // CV_8UC3 rendered image (radiance rounded)
  cv::Mat radiance;  // CV_32FC3 BGR in 8-bit levels, before rounding
  cv::Mat coverage;  // CV_8UC1 1 where the centre sub-sample, i.e. the pixel centre, hits the hand
  cv::Mat samples;   // CV_8UC1 number of the s*s sub-samples that hit the hand
  cv::Mat regions;   // CV_8UC1 region bits (synth/regions.h), dilated by one pixel
};

// The studio's key light (world direction towards it): the one that casts shadows.
synth::Vec3 key_light_direction();

// supersample: odd s >= 1; noise_seed: background noise stream (deterministic per image);
// background_noise: false leaves the background flat (the camera response adds noise later).
SynthView render_synth_view(const SynthSkin& skin, const SynthMeshView& mesh, const Camera& camera,
                            int supersample, uint64_t noise_seed, bool background_noise = true);

}  // namespace handscs
