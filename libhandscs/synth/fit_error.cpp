#include "synth/fit_error.h"

#include <cmath>

#include "synth/motion.h"

namespace handscs {

namespace {

// Sinusoids per channel: three incommensurate ones look like a random smooth signal over a capture.
constexpr int kWaves = 3;
constexpr double kDegree = M_PI / 180.0;

struct Channel {
  std::array<double, kWaves> period{}, phase{};
  double amplitude = 0;
  double at(int frame) const {
    double sum = 0;
    for (int w = 0; w < kWaves; ++w) sum += std::sin(2 * M_PI * frame / period[w] + phase[w]);
    return amplitude * sum;
  }
};

Channel make_channel(SynthRandom& random, double sigma, double period) {
  Channel c;
  for (int w = 0; w < kWaves; ++w) {
    c.period[w] = period * random.uniform(0.6, 1.6);
    c.phase[w] = random.uniform(0, 2 * M_PI);
  }
  c.amplitude = sigma * std::sqrt(2.0 / kWaves);  // each sinusoid has variance a^2 / 2
  return c;
}

}  // namespace

std::vector<FitError> make_fit_errors(const SynthEffects& effects, int num_frames, uint64_t seed) {
  SynthRandom random(mix_seed(seed, 0x666974));  // "fit"
  const double period = effects.fit_period_frames;
  std::array<Channel, 48> pose;
  for (int i = 0; i < 48; ++i) {
    const double angle = (i < 3 ? effects.fit_global_deg : effects.fit_pose_deg) * kDegree;
    pose[i] = make_channel(random, angle / std::sqrt(3.0), period);
  }
  std::array<Channel, 3> trans;
  for (auto& c : trans) c = make_channel(random, effects.fit_trans_mm * 1e-3 / std::sqrt(3.0), period);
  std::array<Channel, 10> shape;
  for (auto& c : shape) c = make_channel(random, effects.fit_shape, period);
  std::vector<FitError> errors(num_frames);
  for (int k = 0; k < num_frames; ++k) {
    for (int i = 0; i < 48; ++i) errors[k].pose[i] = pose[i].at(k);
    for (int i = 0; i < 3; ++i) errors[k].trans[i] = trans[i].at(k);
    for (int i = 0; i < 10; ++i) errors[k].shape[i] = shape[i].at(k);
  }
  return errors;
}

}  // namespace handscs
