#include "synth/skin.h"

#include <algorithm>
#include <cmath>

#include "hand/joint_order.h"
#include "synth/tensor_row.h"

namespace handscs {

using namespace synth;

namespace {

// Skin tones (display RGB): dorsal skin, palmar skin (lighter, pinker), nail plate.
constexpr Vec3 kDorsalSkin = {0.80, 0.58, 0.47};
constexpr Vec3 kPalmarSkin = {0.85, 0.62, 0.53};
constexpr Vec3 kNail = {0.88, 0.71, 0.68};
// Texture scales (m) and amplitudes: blotches ~2 cm, redness ~1.2 cm, fine grain 1.2 mm and 0.5 mm
// (sub-pixel at 1 m, visible through 3x3 supersampling as grain).
constexpr double kBlotchScale = 0.02, kBlotchAmp = 0.06;
constexpr double kRednessScale = 0.012, kRednessAmp = 0.035;
constexpr double kGrainScale = 0.0012, kGrainAmp = 0.035;
constexpr double kPoreScale = 0.0005, kPoreAmp = 0.02;
// Creases: line half-width ~0.5 mm, reaching 16 mm around the joint axis.
constexpr double kCreaseWidth = 0.00045, kCreaseReach = 0.016;
constexpr double kDorsalCreaseDark = 0.18, kPalmarCreaseDark = 0.30, kPalmLineDark = 0.28;
// Flexion-dependent creases (fractions f of a right angle): darkness x (base + gain f), width x
// (1 + widening f). Palmar creases are where the skin folds on flexion, so they change most (faint
// at full extension, ~3x at a right angle); dorsal wrinkles bunch less; flexed knuckles blanch as the
// skin over them stretches.
constexpr double kDorsalFlexBase = 0.5, kDorsalFlexGain = 1.0;
constexpr double kPalmarFlexBase = 0.4, kPalmarFlexGain = 1.6;
constexpr double kCreaseWidening = 1.0, kKnuckleBlanch = 0.06;
constexpr double kPalmFoldBase = 0.5, kPalmFoldGain = 1.2;
// Fold occlusion: neighbourhood radius and strength.
constexpr double kFoldRadius = 0.011, kFoldStrength = 0.28;

// Lattice value in [-1, 1): a multiplicative hash of the cell and the seed with one 64-bit
// finaliser (fast; the texture only needs decorrelated cells, not cryptographic mixing).
double lattice(int64_t x, int64_t y, int64_t z, uint64_t seed) {
  uint64_t h = static_cast<uint64_t>(x) * 0x8da6b343ull ^ static_cast<uint64_t>(y) * 0xd8163841ull ^
               static_cast<uint64_t>(z) * 0xcb1ab31full ^ (seed * 0x9e3779b97f4a7c15ull);
  h ^= h >> 33;
  h *= 0xff51afd7ed558ccdull;
  h ^= h >> 33;
  h *= 0xc4ceb9fe1a85ec53ull;
  h ^= h >> 33;
  return static_cast<double>(h >> 11) * 0x1.0p-52 - 1.0;
}

// Smooth value noise in [-1, 1] with features of size `scale`.
double value_noise(const Vec3& p, double scale, uint64_t seed) {
  const double qx = p[0] / scale, qy = p[1] / scale, qz = p[2] / scale;
  const double fx0 = std::floor(qx), fy0 = std::floor(qy), fz0 = std::floor(qz);
  const int64_t ix = static_cast<int64_t>(fx0), iy = static_cast<int64_t>(fy0),
                iz = static_cast<int64_t>(fz0);
  auto fade = [](double t) { return t * t * (3 - 2 * t); };
  const double fx = fade(qx - fx0), fy = fade(qy - fy0), fz = fade(qz - fz0);
  double result = 0;
  for (int c = 0; c < 8; ++c) {
    const int dx = c & 1, dy = (c >> 1) & 1, dz = (c >> 2) & 1;
    const double w = (dx ? fx : 1 - fx) * (dy ? fy : 1 - fy) * (dz ? fz : 1 - fz);
    result += w * lattice(ix + dx, iy + dy, iz + dz, seed);
  }
  return result;
}

double smoothstep(double lo, double hi, double x) {
  const double t = std::clamp((x - lo) / (hi - lo), 0.0, 1.0);
  return t * t * (3 - 2 * t);
}

double line_profile(double distance, double width = kCreaseWidth) {
  return std::exp(-(distance * distance) / (width * width));
}

}  // namespace

SynthSkin make_synth_skin(const Rig& rig, uint64_t seed) {
  SynthSkin skin;
  skin.seed = seed;
  const torch::Tensor vt = rig.v_template.to(torch::kFloat64).contiguous();
  const int64_t num_vertices = vt.size(0);
  skin.canonical.resize(num_vertices * 3);
  const double* v = vt.data_ptr<double>();
  for (int64_t i = 0; i < num_vertices * 3; ++i) skin.canonical[i] = static_cast<float>(v[i]);
  skin.nail.assign(num_vertices, 0.0f);
  skin.palmar.assign(num_vertices, 0.0f);
  if (rig.vertex_labels.defined() && rig.vertex_labels.numel() == num_vertices) {
    const torch::Tensor labels = rig.vertex_labels.to(torch::kInt64).contiguous();
    const int64_t* l = labels.data_ptr<int64_t>();
    for (int64_t i = 0; i < num_vertices; ++i) {
      skin.nail[i] = l[i] == 1 ? 1.0f : 0.0f;
      skin.palmar[i] = l[i] == 2 ? 1.0f : 0.0f;
    }
  }
  const torch::Tensor joints = torch::matmul(rig.j_regressor.to(torch::kFloat64), vt).contiguous();
  auto J = [&](int k) { return tensor_row(joints, k); };
  for (int f = 0; f < kFingers; ++f) {
    const auto& chain = kFingerJoints[f];
    const Vec3 tip = tensor_row(vt, rig.tip_vertices[f]);
    for (int k = 0; k < 3; ++k) {
      const Vec3 next = k < 2 ? J(chain[k + 1]) : tip;
      skin.crease_centre.push_back(J(chain[k]));
      skin.crease_axis.push_back(normalized(next - J(chain[k])));
      skin.crease_kind.push_back(k);
    }
  }
  skin.wrist = J(0);
  const Vec3 knuckles = (J(1) + J(4) + J(10) + J(7)) * 0.25;
  skin.palm_long = normalized(knuckles - skin.wrist);
  skin.palm_length = norm(knuckles - skin.wrist);
  const Vec3 thumb = J(13) - skin.wrist;
  skin.palm_across = normalized(thumb - skin.palm_long * dot(thumb, skin.palm_long));
  skin.palm_back = cross(skin.palm_long, skin.palm_across);
  skin.palm_width = std::max(1e-3, std::fabs(dot(J(1) - J(7), skin.palm_across)));
  return skin;
}

Vec3 skin_albedo(const SynthSkin& skin, const Vec3& p, double nail, double palmar,
                 const SkinFlexion* flexion, double* crease) {
  const uint64_t seed = skin.seed;
  Vec3 colour = kDorsalSkin * (1 - palmar) + kPalmarSkin * palmar;
  const double blotch = 1 + kBlotchAmp * value_noise(p, kBlotchScale, seed + 1);
  colour = colour * blotch;
  const double redness = kRednessAmp * value_noise(p, kRednessScale, seed + 2);
  colour[0] += redness;
  colour[2] -= 0.6 * redness;

  double dark = 0;  // accumulated crease/line darkening
  const double dorsal = 1 - palmar;
  const double broken = 0.6 + 0.4 * value_noise(p, 0.002, seed + 3);  // lines fade in and out
  for (size_t c = 0; c < skin.crease_centre.size(); ++c) {
    const Vec3 offset = p - skin.crease_centre[c];
    const double s = dot(offset, skin.crease_axis[c]);
    if (std::fabs(s) > 0.016) continue;
    const double radial = norm(offset - skin.crease_axis[c] * s);
    if (radial > kCreaseReach) continue;
    const int kind = skin.crease_kind[c];
    // Static creases, or creases that deepen, widen and darken with the joint's flexion.
    double dorsal_gain = 1, palmar_gain = 1, width = kCreaseWidth, blanch = 0, redden = 1;
    if (flexion) {
      const double f = std::clamp(flexion->joint[c], 0.0, 1.2);
      dorsal_gain = kDorsalFlexBase + kDorsalFlexGain * f;
      palmar_gain = kPalmarFlexBase + kPalmarFlexGain * f;
      width = kCreaseWidth * (1 + kCreaseWidening * f);
      blanch = kKnuckleBlanch * f;
      redden = 1 - std::min(1.0, f);
    }
    // Darkening of this joint's lines for given gains and width.
    auto lines = [&](double dorsal_g, double palmar_g, double w) {
      if (kind == 0)  // the palmar digital crease past the knuckle
        return kPalmarCreaseDark * palmar_g * palmar * line_profile(s - 0.011, w) * broken;
      const double spacing = kind == 1 ? 0.0022 : 0.0013;  // PIP wrinkles spread wider than DIP
      double sum = kPalmarCreaseDark * palmar_g * palmar *
                   (line_profile(s - 0.0008, w) + line_profile(s + 0.0008, w)) * broken;
      for (int k = -1; k <= 1; ++k)
        sum += kDorsalCreaseDark * dorsal_g * dorsal * line_profile(s - k * spacing, w) * broken;
      return sum;
    };
    double patch = 0;
    if (kind == 0) {
      // Knuckle: a faint reddish patch on the back of the hand, stretched and blanched when the
      // joint flexes.
      patch = std::exp(-(s * s + radial * radial * 0.2) / (0.006 * 0.006)) * dorsal;
      colour[0] += 0.03 * patch * redden + blanch * patch;
      colour[1] += -0.02 * patch * redden + blanch * patch;
      colour[2] += blanch * patch;
    }
    dark += lines(dorsal_gain, palmar_gain, width);
    // The crease region: the union of the static and the flexed lines' footprints, and the
    // blanched knuckle (the skin that changes with flexion).
    if (crease && flexion)
      *crease += lines(std::max(1.0, dorsal_gain), std::max(1.0, palmar_gain),
                       std::max(kCreaseWidth, width)) +
                 blanch * patch;
  }

  if (palmar > 0) {
    // Palm lines in palm coordinates: l along the palm (0 wrist, 1 knuckles), c across (+ thumb).
    const Vec3 q = p - skin.wrist;
    const double l = dot(q, skin.palm_long) / skin.palm_length;
    const double c = dot(q, skin.palm_across) / skin.palm_width;
    const double L = skin.palm_length;
    // Palm lines deepen as the palm folds (cupping): the fold gathers skin into them.
    const double fold_gain = flexion ? kPalmFoldBase + kPalmFoldGain * flexion->palm_fold : 1.0;
    const double line_broken = (0.7 + 0.3 * (broken - 0.6) / 0.4) * fold_gain;
    const double dark_before = dark;
    if (l > 0.05 && l < 1.0) {
      if (c > -0.6 && c < 0.25) {  // heart line: pinky edge towards the index/middle gap
        const double line = 0.76 + 0.14 * std::pow(std::max(0.0, (c + 0.6) / 0.85), 1.5);
        const double ends = smoothstep(-0.6, -0.5, c) * (1 - smoothstep(0.15, 0.25, c));
        dark += kPalmLineDark * palmar * ends * line_broken * line_profile((l - line) * L);
      }
      if (c > -0.4 && c < 0.5) {  // head line: thumb side running across, slightly descending
        const double line = 0.70 - 0.18 * (0.5 - c) / 0.9;
        const double ends = smoothstep(-0.4, -0.3, c) * (1 - smoothstep(0.4, 0.5, c));
        dark += kPalmLineDark * palmar * ends * line_broken * line_profile((l - line) * L);
      }
      {  // life line: an arc around the thumb's ball
        const double dl = (l - 0.30) * L, dc = (c - 0.60) * skin.palm_width;
        const double radius = 0.42 * L;
        const double ends =
            smoothstep(0.12, 0.2, l) * (1 - smoothstep(0.62, 0.7, l)) * (c < 0.55 ? 1.0 : 0.0);
        dark += kPalmLineDark * palmar * ends * line_broken *
                line_profile(std::sqrt(dl * dl + dc * dc) - radius);
      }
    }
    if (crease && flexion) *crease += dark - dark_before;
  }
  colour = colour * (1 - std::min(0.6, dark));

  if (nail > 0) {
    const double n = std::clamp(nail, 0.0, 1.0);
    const Vec3 plate = kNail * (1 + 0.03 * value_noise(p, 0.003, seed + 50));
    colour = colour * (1 - n) + plate * n;
    const double cuticle = std::exp(-((n - 0.5) * (n - 0.5)) / (0.18 * 0.18));  // nail border
    colour = colour * (1 - 0.12 * cuticle);
  }
  const double grain = 1 + kGrainAmp * value_noise(p, kGrainScale, seed + 60) +
                       kPoreAmp * value_noise(p, kPoreScale, seed + 61);
  colour = colour * grain;
  for (double& x : colour) x = std::clamp(x, 0.0, 1.0);
  return colour;
}

std::vector<float> vertex_normals(const std::vector<float>& vertices,
                                  const std::vector<int64_t>& faces) {
  std::vector<double> acc(vertices.size(), 0.0);
  for (size_t f = 0; f + 2 < faces.size(); f += 3) {
    const int64_t a = faces[f], b = faces[f + 1], c = faces[f + 2];
    const Vec3 pa = {vertices[a * 3], vertices[a * 3 + 1], vertices[a * 3 + 2]};
    const Vec3 pb = {vertices[b * 3], vertices[b * 3 + 1], vertices[b * 3 + 2]};
    const Vec3 pc = {vertices[c * 3], vertices[c * 3 + 1], vertices[c * 3 + 2]};
    const Vec3 n = cross(pb - pa, pc - pa);  // length = 2 area: area weighting
    for (int64_t id : {a, b, c})
      for (int d = 0; d < 3; ++d) acc[id * 3 + d] += n[d];
  }
  std::vector<float> normals(vertices.size());
  for (size_t v = 0; v < vertices.size() / 3; ++v) {
    const Vec3 n = normalized({acc[v * 3], acc[v * 3 + 1], acc[v * 3 + 2]});
    for (int d = 0; d < 3; ++d) normals[v * 3 + d] = static_cast<float>(n[d]);
  }
  return normals;
}

std::vector<float> fold_occlusion(const std::vector<float>& vertices,
                                  const std::vector<float>& normals) {
  const size_t count = vertices.size() / 3;
  std::vector<float> occlusion(count, 0.0f);
  const float r2 = static_cast<float>(kFoldRadius * kFoldRadius);
  for (size_t i = 0; i < count; ++i) {
    const float px = vertices[i * 3], py = vertices[i * 3 + 1], pz = vertices[i * 3 + 2];
    const float nx = normals[i * 3], ny = normals[i * 3 + 1], nz = normals[i * 3 + 2];
    double sum = 0;
    for (size_t j = 0; j < count; ++j) {
      const float dx = vertices[j * 3] - px, dy = vertices[j * 3 + 1] - py,
                  dz = vertices[j * 3 + 2] - pz;
      const float d2 = dx * dx + dy * dy + dz * dz;
      if (d2 >= r2 || d2 <= 1e-12f) continue;
      const float d = std::sqrt(d2);
      const float facing = (nx * dx + ny * dy + nz * dz) / d;
      if (facing <= 0) continue;
      const float falloff = 1 - d / static_cast<float>(kFoldRadius);
      sum += falloff * falloff * facing;
    }
    occlusion[i] = static_cast<float>(1 - std::exp(-kFoldStrength * sum));
  }
  return occlusion;
}

}  // namespace handscs
