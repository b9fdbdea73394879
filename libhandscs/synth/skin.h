// Procedural skin of the synthetic hand, evaluated at canonical (rest-pose) surface points so the
// texture moves with the skin (creases optionally deepening with flexion): albedo = base skin (low-frequency tint) with palmar tone, nails,
// knuckle and flexion creases, palm lines and fine noise; plus per-vertex fold occlusion of a posed
// mesh, occ_i = 1 - exp(-k sum_j (1 - d_ij / r)^2 max(0, n_i . (p_j - p_i) / d_ij)), which darkens
// skin folds at bent joints and between touching fingers.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "synth/math.h"
#include "hand/rig.h"

namespace handscs {

struct SynthSkin {
  std::vector<float> canonical;  // [V * 3] rest vertices (shape 0), metres: texture coordinates
  std::vector<float> nail;       // [V] 1 on nail vertices (label 1)
  std::vector<float> palmar;     // [V] 1 on palmar skin (label 2)
  // Crease frames: joint centre and the direction of the bone leaving it, rest pose.
  std::vector<synth::Vec3> crease_centre, crease_axis;
  std::vector<int> crease_kind;  // 0 MCP, 1 PIP, 2 DIP (thumb: CMC, MCP, IP)
  // Palm frame: long = wrist to knuckles, across = towards the thumb, back = long x across
  // (the back of a right hand; the palm side of a left hand).
  synth::Vec3 wrist, palm_long, palm_across, palm_back;
  double palm_length = 0.09, palm_width = 0.08;
  uint64_t seed = 1;
};

SynthSkin make_synth_skin(const Rig& rig, uint64_t seed);

// Flexion of the joints under the creases, as fractions of a right angle, in the order of
// SynthSkin::crease_centre (finger-major, base to distal), and the palm's fold (0 flat, 1 cupped).
struct SkinFlexion {
  std::array<double, 15> joint{};
  double palm_fold = 0;
};

// Albedo (display RGB in [0, 1]) at canonical point p with interpolated nail/palmar weights.
// flexion null: static creases (the easy captures); else creases follow the flexion, and `crease`
// (if given) accumulates the darkening of the flexion-dependent lines at p.
synth::Vec3 skin_albedo(const SynthSkin& skin, const synth::Vec3& p, double nail, double palmar,
                        const SkinFlexion* flexion = nullptr, double* crease = nullptr);

// Area-weighted vertex normals [V * 3] of a triangle mesh (faces counter-clockwise from outside).
std::vector<float> vertex_normals(const std::vector<float>& vertices,
                                  const std::vector<int64_t>& faces);

// Fold occlusion in [0, 1) per vertex of a posed mesh (formula above).
std::vector<float> fold_occlusion(const std::vector<float>& vertices,
                                  const std::vector<float>& normals);

}  // namespace handscs
