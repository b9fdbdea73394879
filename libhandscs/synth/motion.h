// Range-of-motion pose sequence for a rig: finger flexion waves, finger spread, thumb opposition,
// and wrist rotation (pronation, flexion, deviation), smooth in time and deterministic from a seed.
// Joint axes come from the rig's rest skeleton (bone directions, the palm normal oriented by the
// palmar/nail vertex labels), so the motion is anatomical for any MANO-layout rig.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "hand/rig.h"
#include "synth/articulation.h"

namespace handscs {

// Amplitudes (rad) of the slow wrist motion of both the range-of-motion sequence and the gestures
// (synth/gestures.h): pronation/supination, flexion/extension, deviation.
struct WristAmplitudes {
  static constexpr double pronation = 0.6, flexion = 0.3, deviation = 0.12;
};

struct SynthPose {
  std::array<double, 48> pose{};   // absolute axis-angle (flat_hand_mean = true), MANO joint order
  std::array<double, 10> shape{};  // a per-capture base shape plus a small per-frame jitter
  HandArticulation articulation;   // what `pose` was made from (tissue and skin read the flexion)
};

// `num_frames` poses along a range-of-motion cycle (about one flexion cycle per 30 frames).
std::vector<SynthPose> make_rom_poses(const Rig& rig, int num_frames, uint64_t seed);

// Deterministic random numbers (SplitMix64): the same stream on every platform and thread count.
class SynthRandom {
 public:
  explicit SynthRandom(uint64_t seed) : state_(seed) {}
  uint64_t next();
  double uniform();                      // [0, 1)
  double uniform(double lo, double hi);  // [lo, hi)
  double normal();                       // N(0, 1), Box-Muller
 private:
  uint64_t state_;
};

// Mixes several integers into one seed (for per-image noise streams).
uint64_t mix_seed(uint64_t a, uint64_t b, uint64_t c = 0);

}  // namespace handscs
