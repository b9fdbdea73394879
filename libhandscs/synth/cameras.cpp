#include "synth/cameras.h"

#include <cmath>

#include "core/error.h"
#include "synth/motion.h"

namespace handscs {

using namespace synth;

namespace {
// Band of camera directions, as the cosine of the angle to `up`: cameras neither straight below
// (along the forearm) nor straight above the fingertips, like a capture dome around a raised hand.
constexpr double kLowestCos = -0.45, kHighestCos = 0.75;
// Golden angle: successive cameras spread evenly in azimuth (Fibonacci sphere).
const double kGoldenAngle = M_PI * (3.0 - std::sqrt(5.0));
// Reference image size of InterHand2.6M's cameras (portrait); focal lengths scale with it.
constexpr double kReferenceWidth = 334.0;
}  // namespace

std::vector<SynthCamera> make_synth_cameras(const SynthConfig& config, const Vec3& target,
                                            const Vec3& up, const Vec3& side) {
  require(config.num_cameras > 0, "synth: num_cameras must be positive");
  SynthRandom random(mix_seed(config.seed, 0x63616d657261));  // "camera"
  const Vec3 u = normalized(up);
  const Vec3 e1 = normalized(side - u * dot(side, u));
  const Vec3 e2 = cross(u, e1);
  const double azimuth0 = random.uniform(0, 2 * M_PI);
  const double scale = config.width / kReferenceWidth;
  std::vector<SynthCamera> cameras;
  for (int i = 0; i < config.num_cameras; ++i) {
    const double h = kLowestCos + (kHighestCos - kLowestCos) * (i + 0.5) / config.num_cameras;
    const double azimuth = azimuth0 + i * kGoldenAngle;
    const double r = std::sqrt(1 - h * h);
    const Vec3 direction = u * h + e1 * (r * std::cos(azimuth)) + e2 * (r * std::sin(azimuth));
    const double distance = config.camera_distance * random.uniform(0.95, 1.08);
    const Vec3 centre = target + direction * distance;
    // Aim a little off the hand centre (up to 1.5 cm) so the hand is not always mid-image.
    const Vec3 aim =
        target + Vec3{random.uniform(-1, 1), random.uniform(-1, 1), random.uniform(-1, 1)} * 0.015;
    const Vec3 z = normalized(aim - centre);
    const Vec3 down = u * -1.0;
    Vec3 x = normalized(cross(down, z));  // image x: right; y = z x x: down in the image
    Vec3 y = cross(z, x);
    SynthCamera cam;
    cam.landscape =
        config.landscape_every > 0 && i % config.landscape_every == config.landscape_every - 1;
    int width = config.width, height = config.height;
    if (cam.landscape) {  // roll 90 degrees about the optical axis: the hand lies sideways
      const Vec3 rolled_x = y * -1.0;
      y = x;
      x = rolled_x;
      std::swap(width, height);
    }
    cam.id = std::to_string(400002 + 2 * i);
    for (int d = 0; d < 3; ++d) {
      cam.raw.camrot[d] = x[d];
      cam.raw.camrot[3 + d] = y[d];
      cam.raw.camrot[6 + d] = z[d];
      cam.raw.campos_mm[d] = centre[d] * 1000.0;
    }
    const double focal = config.focal * scale;
    cam.raw.focal = {focal * random.uniform(0.995, 1.008), focal * random.uniform(0.995, 1.008)};
    cam.raw.princpt = {width * 0.5 + 8.0 * scale * random.normal(),
                       height * 0.5 + 8.0 * scale * random.normal()};
    cam.camera = camera_from_interhand(cam.raw, width, height);
    cameras.push_back(cam);
  }
  return cameras;
}

}  // namespace handscs
