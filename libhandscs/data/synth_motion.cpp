#include "data/synth_motion.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "data/synth_math.h"
#include "hand/joint_order.h"

namespace handscs {

using namespace synth;

uint64_t SynthRandom::next() {
  uint64_t z = (state_ += 0x9e3779b97f4a7c15ull);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  return z ^ (z >> 31);
}

double SynthRandom::uniform() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }

double SynthRandom::uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }

double SynthRandom::normal() {
  const double u1 = std::max(uniform(), 1e-300), u2 = uniform();
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * M_PI * u2);
}

uint64_t mix_seed(uint64_t a, uint64_t b, uint64_t c) {
  SynthRandom r(a * 0x9e3779b97f4a7c15ull ^ (b + 0x632be59bd9b4e019ull) * 0xff51afd7ed558ccdull ^
                (c + 0x8cb92ba72f3d8dd7ull) * 0xc4ceb9fe1a85ec53ull);
  return r.next();
}

namespace {

constexpr double kTwoPi = 2.0 * M_PI;
// Frames per flexion cycle: slow enough that consecutive 5 fps frames differ by a few degrees.
constexpr double kFramesPerCycle = 30.0;

// Joint angle ranges (rad) of the motion, inside the human range of motion (MCP flexion to ~90
// degrees, PIP ~100, DIP ~70; spread ~+-12 degrees; forearm pronation/supination ~+-35 degrees).
constexpr double kMcpFlex = 1.1, kPipFlex = 1.3, kDipFlex = 0.8, kMcpExtension = -0.12;
constexpr double kSpread = 0.2;
constexpr double kThumbOpposition = 0.85, kThumbFlex = 0.6;
constexpr double kPronation = 0.6, kWristFlex = 0.3, kWristDeviation = 0.12;
// Shape: per-capture base ~ N(0, 0.5^2) on the modes, per-frame jitter ~ N(0, 0.04^2) (the real
// annotations refit the shape for every frame).
constexpr double kShapeBase = 0.5, kShapeJitter = 0.04, kShapeClamp = 1.2;

Vec3 row(const torch::Tensor& t, int64_t i) {
  const double* p = t[i].data_ptr<double>();
  return {p[0], p[1], p[2]};
}

struct Axes {
  Vec3 long_axis, palm_normal, wrist_flex;
  std::array<std::array<Vec3, 3>, 5> flex;  // [finger][joint] flexion axes
  std::array<double, 5> spread_sign{};
  double opposition_sign = 1;
};

Axes rig_axes(const Rig& rig) {
  const torch::Tensor vt = rig.v_template.to(torch::kFloat64).contiguous();
  const torch::Tensor joints = torch::matmul(rig.j_regressor.to(torch::kFloat64), vt).contiguous();
  auto J = [&](int k) { return row(joints, k); };
  auto tip = [&](int f) { return row(vt, rig.tip_vertices[f]); };
  Axes axes;
  const Vec3 wrist = J(0);
  const Vec3 knuckles = (J(1) + J(4) + J(10) + J(7)) * 0.25;
  axes.long_axis = normalized(knuckles - wrist);
  Vec3 n = normalized(cross(J(1) - wrist, J(7) - wrist));
  // Orient the palm normal towards the palmar side: from the labels when present (palmar skin
  // label 2), else from handedness (right hand: palm normal = thumb side x finger direction).
  bool oriented = false;
  if (rig.vertex_labels.defined() && rig.vertex_labels.numel() == rig.num_vertices()) {
    const torch::Tensor labels = rig.vertex_labels.to(torch::kInt64).contiguous();
    const torch::Tensor palmar = labels.eq(2);
    if (palmar.any().item<bool>()) {
      const torch::Tensor c_palmar = vt.index({palmar}).mean(0).contiguous();
      const torch::Tensor c_all = vt.mean(0).contiguous();
      const Vec3 towards = row(c_palmar.unsqueeze(0), 0) - row(c_all.unsqueeze(0), 0);
      if (dot(n, towards) < 0) n = n * -1.0;
      oriented = true;
    }
  }
  if (!oriented) {
    const Vec3 thumb_side = J(13) - knuckles;
    Vec3 expected = normalized(cross(thumb_side, axes.long_axis));
    if (rig.handedness == Handedness::left) expected = expected * -1.0;
    if (dot(n, expected) < 0) n = n * -1.0;
  }
  axes.palm_normal = n;
  axes.wrist_flex = normalized(cross(axes.long_axis, n));

  // Thumb palmar direction: opposite to its nail (labels 1 weighted mostly by thumb joints).
  Vec3 thumb_palmar = n;
  if (rig.vertex_labels.defined() && rig.vertex_labels.numel() == rig.num_vertices()) {
    const torch::Tensor labels = rig.vertex_labels.to(torch::kInt64).contiguous();
    const torch::Tensor owner = rig.weights.argmax(1).contiguous();
    const Vec3 base = J(15), dir = normalized(tip(kThumb) - J(15));
    Vec3 sum{0, 0, 0};
    int count = 0;
    for (int64_t v = 0; v < rig.num_vertices(); ++v) {
      const int64_t o = owner[v].item<int64_t>();
      if (labels[v].item<int64_t>() != 1 || (o != 13 && o != 14 && o != 15)) continue;
      const Vec3 offset = row(vt, v) - base;
      sum = sum + (offset - dir * dot(offset, dir));
      ++count;
    }
    if (count > 0) thumb_palmar = normalized(sum) * -1.0;
  }

  for (int f = 0; f < kFingers; ++f) {
    const auto& chain = kFingerJoints[f];
    const Vec3 dirs[3] = {J(chain[1]) - J(chain[0]), J(chain[2]) - J(chain[1]),
                          tip(f) - J(chain[2])};
    const Vec3 palmar = f == kThumb ? thumb_palmar : n;
    // Rotating bone d about (d x palmar) moves its end towards the palmar side.
    for (int k = 0; k < 3; ++k) axes.flex[f][k] = normalized(cross(dirs[k], palmar));
    if (f != kThumb && f != kMiddle) {
      const Vec3 side = J(chain[0]) - J(kFingerJoints[kMiddle][0]);
      axes.spread_sign[f] = dot(cross(n, dirs[0]), side) > 0 ? 1.0 : -1.0;
    }
  }
  const Vec3 thumb_reach = tip(kThumb) - J(13);
  axes.opposition_sign = dot(cross(axes.long_axis, thumb_reach), n) > 0 ? 1.0 : -1.0;
  return axes;
}

}  // namespace

std::vector<SynthPose> make_rom_poses(const Rig& rig, int num_frames, uint64_t seed) {
  require(num_frames > 0, "make_rom_poses: num_frames must be positive");
  const Axes axes = rig_axes(rig);
  SynthRandom random(mix_seed(seed, 0x6d6f74696f6e));  // "motion"
  const double cycles = std::max(1.0, num_frames / kFramesPerCycle);
  const double phase_fist = random.uniform(0, kTwoPi), phase_spread = random.uniform(0, kTwoPi);
  const double phase_opp = random.uniform(0, kTwoPi), phase_pron = random.uniform(0, kTwoPi);
  const double phase_wflex = random.uniform(0, kTwoPi), phase_dev = random.uniform(0, kTwoPi);
  std::array<double, 5> amplitude{};
  for (double& a : amplitude) a = random.uniform(0.85, 1.0);
  std::array<double, 10> base_shape{};
  for (int i = 0; i < 10; ++i)
    base_shape[i] = std::clamp(kShapeBase * random.normal(), -kShapeClamp, kShapeClamp);

  std::vector<SynthPose> poses(num_frames);
  for (int k = 0; k < num_frames; ++k) {
    const double t = static_cast<double>(k) / num_frames;
    const double w = kTwoPi * cycles * t;
    std::array<double, 5> fist{};
    double fist_mean = 0;
    for (int f = 1; f < kFingers; ++f) {
      // A flexion wave running across the fingers (index first).
      fist[f] = amplitude[f] * (0.5 - 0.5 * std::cos(w + phase_fist - 0.6 * f));
      fist_mean += fist[f] / 4.0;
    }
    const double spread = kSpread * std::sin(0.7 * w + phase_spread) * (1.0 - 0.8 * fist_mean);
    const double opposition = 0.5 - 0.5 * std::cos(0.8 * w + phase_opp);

    std::array<Mat3, 16> local;
    local.fill(identity3());
    local[0] = mul(mul(rotation(axes.long_axis, kPronation * std::sin(0.5 * w + phase_pron)),
                       rotation(axes.wrist_flex, kWristFlex * std::sin(0.6 * w + phase_wflex))),
                   rotation(axes.palm_normal, kWristDeviation * std::sin(0.9 * w + phase_dev)));
    for (int f = 1; f < kFingers; ++f) {
      const auto& chain = kFingerJoints[f];
      local[chain[0]] =
          mul(rotation(axes.flex[f][0], kMcpExtension + (kMcpFlex - kMcpExtension) * fist[f]),
              rotation(axes.palm_normal, axes.spread_sign[f] * spread));
      local[chain[1]] = rotation(axes.flex[f][1], kPipFlex * fist[f]);
      local[chain[2]] = rotation(axes.flex[f][2], kDipFlex * fist[f]);
    }
    const auto& thumb = kFingerJoints[kThumb];
    local[thumb[0]] =
        mul(rotation(axes.long_axis, axes.opposition_sign * kThumbOpposition * opposition),
            rotation(axes.flex[kThumb][0], 0.2 * opposition));
    local[thumb[1]] = rotation(axes.flex[kThumb][1], 0.1 + kThumbFlex * opposition);
    local[thumb[2]] = rotation(axes.flex[kThumb][2], 0.15 + kThumbFlex * (0.3 + 0.7 * fist_mean));

    SynthPose& pose = poses[k];
    for (int j = 0; j < 16; ++j) {
      const Vec3 aa = axis_angle(local[j]);
      for (int d = 0; d < 3; ++d) pose.pose[j * 3 + d] = aa[d];
    }
    SynthRandom jitter(mix_seed(seed, 0x7368617065, k));  // "shape"
    for (int i = 0; i < 10; ++i) pose.shape[i] = base_shape[i] + kShapeJitter * jitter.normal();
  }
  return poses;
}

}  // namespace handscs
