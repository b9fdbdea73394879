#include "synth/camera_response.h"

#include <algorithm>
#include <cmath>

#include "synth/motion.h"

namespace handscs {

namespace {
// Lens fall-off at the image corners: 10-25% for the small lenses of capture domes.
constexpr double kVignettingLo = 0.1, kVignettingHi = 0.25;
// Rec. 601 luma weights (R, G, B).
constexpr double kLuma[3] = {0.299, 0.587, 0.114};
}  // namespace

std::vector<CameraResponse> make_camera_responses(const SynthEffects& e, int num_cameras,
                                                  uint64_t seed) {
  SynthRandom random(mix_seed(seed, 0x726573706f6e7365));  // "response"
  std::vector<CameraResponse> responses(num_cameras);
  for (int i = 0; i < num_cameras; ++i) {
    CameraResponse& r = responses[i];
    r.gain = random.uniform(1 - e.gain_spread, 1 + e.gain_spread);
    r.white_balance[0] = 1 + e.white_balance_spread * random.normal();
    r.white_balance[2] = 1 + e.white_balance_spread * random.normal();
    r.vignetting = random.uniform(kVignettingLo, kVignettingHi);
    r.monochrome = e.monochrome_every > 0 && i % e.monochrome_every == e.monochrome_every - 1;
  }
  return responses;
}

cv::Mat expose(const cv::Mat& radiance, const CameraResponse& r, const SynthEffects& e,
               uint64_t noise_seed) {
  const int width = radiance.cols, height = radiance.rows;
  cv::Mat out(height, width, CV_8UC3);
  SynthRandom random(noise_seed);
  const double cx = 0.5 * width, cy = 0.5 * height;
  const double inv_diag2 = 1.0 / (cx * cx + cy * cy);
  // Box-Muller costs a log, a sqrt and a cosine per sample: the sum of four uniforms (Irwin-Hall,
  // variance 1/3 each) is Gaussian enough for sensor noise.
  auto gauss = [&random] {
    return (random.uniform() + random.uniform() + random.uniform() + random.uniform() - 2.0) *
           std::sqrt(3.0);
  };
  for (int y = 0; y < height; ++y) {
    const float* in = radiance.ptr<float>(y);
    uint8_t* o = out.ptr<uint8_t>(y);
    for (int x = 0; x < width; ++x) {
      const double dx = x + 0.5 - cx, dy = y + 0.5 - cy;
      const double fall = r.gain * (1 - r.vignetting * (dx * dx + dy * dy) * inv_diag2);
      double rgb[3] = {in[x * 3 + 2] * r.white_balance[0] * fall,
                       in[x * 3 + 1] * r.white_balance[1] * fall,
                       in[x * 3 + 0] * r.white_balance[2] * fall};
      if (r.monochrome) {
        const double luma = kLuma[0] * rgb[0] + kLuma[1] * rgb[1] + kLuma[2] * rgb[2];
        const double noisy =
            luma + std::sqrt(e.read_noise * e.read_noise + e.shot_noise * std::max(0.0, luma)) *
                       gauss();
        rgb[0] = rgb[1] = rgb[2] = noisy;
      } else {
        for (double& c : rgb)
          c += std::sqrt(e.read_noise * e.read_noise + e.shot_noise * std::max(0.0, c)) * gauss();
      }
      for (int c = 0; c < 3; ++c)
        o[x * 3 + 2 - c] = static_cast<uint8_t>(std::clamp(std::lround(rgb[c]), 0L, 255L));
    }
  }
  return out;
}

}  // namespace handscs
