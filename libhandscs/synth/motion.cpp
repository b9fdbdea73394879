#include "synth/motion.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "synth/math.h"
#include "hand/joint_order.h"
#include "synth/articulation.h"

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
// Shape: per-capture base ~ N(0, 0.5^2) on the modes, per-frame jitter ~ N(0, 0.04^2) (the real
// annotations refit the shape for every frame).
constexpr double kShapeBase = 0.5, kShapeJitter = 0.04, kShapeClamp = 1.2;

}  // namespace

std::vector<SynthPose> make_rom_poses(const Rig& rig, int num_frames, uint64_t seed) {
  require(num_frames > 0, "make_rom_poses: num_frames must be positive");
  const HandAxes axes = rig_axes(rig);
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

    HandArticulation a;
    a.pronation = WristAmplitudes::pronation * std::sin(0.5 * w + phase_pron);
    a.wrist_flex = WristAmplitudes::flexion * std::sin(0.6 * w + phase_wflex);
    a.wrist_deviation = WristAmplitudes::deviation * std::sin(0.9 * w + phase_dev);
    for (int f = 1; f < kFingers; ++f) {
      a.flex[f] = {kMcpExtension + (kMcpFlex - kMcpExtension) * fist[f], kPipFlex * fist[f],
                   kDipFlex * fist[f]};
      a.spread[f] = spread;
    }
    a.thumb_opposition = kThumbOpposition * opposition;
    a.flex[kThumb] = {0.2 * opposition, 0.1 + kThumbFlex * opposition,
                      0.15 + kThumbFlex * (0.3 + 0.7 * fist_mean)};

    SynthPose& pose = poses[k];
    pose.articulation = a;
    pose.pose = articulate(axes, a);
    SynthRandom jitter(mix_seed(seed, 0x7368617065, k));  // "shape"
    for (int i = 0; i < 10; ++i) pose.shape[i] = base_shape[i] + kShapeJitter * jitter.normal();
  }
  return poses;
}

}  // namespace handscs
