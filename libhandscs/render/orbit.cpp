#include "render/orbit.h"

#include <cmath>

#include "core/error.h"

namespace handscs {

namespace {
using Vec = std::array<double, 3>;
Vec sub(const Vec& a, const Vec& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
Vec scale(const Vec& a, double s) { return {a[0] * s, a[1] * s, a[2] * s}; }
Vec add(const Vec& a, const Vec& b) { return {a[0] + b[0], a[1] + b[1], a[2] + b[2]}; }
double dot(const Vec& a, const Vec& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
Vec cross(const Vec& a, const Vec& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
Vec normalized(const Vec& a) { return scale(a, 1.0 / std::sqrt(dot(a, a))); }
}  // namespace

std::vector<Camera> orbit_cameras(const Vec& centre, const Vec& axis_in, double extent,
                                  const OrbitSpec& spec) {
  require(spec.count >= 1, "--orbit: at least one view");
  require(dot(axis_in, axis_in) > 0, "orbit: the hand's long axis has zero length");
  const Vec axis = normalized(axis_in);
  // Two directions perpendicular to the axis.
  const Vec helper = std::fabs(axis[0]) < 0.9 ? Vec{1, 0, 0} : Vec{0, 1, 0};
  const Vec e1 = normalized(cross(axis, helper));
  const Vec e2 = cross(axis, e1);
  const double distance = spec.focal * extent / (spec.fill * std::min(spec.width, spec.height));
  std::vector<Camera> cameras;
  for (int k = 0; k < spec.count; ++k) {
    const double phi = 2 * M_PI * k / spec.count;
    const Vec around = add(scale(e1, std::cos(phi)), scale(e2, std::sin(phi)));
    const Vec dir = add(scale(around, std::cos(spec.elevation)), scale(axis, std::sin(spec.elevation)));
    const Vec position = add(centre, scale(dir, distance));
    const Vec z = normalized(sub(centre, position));          // forward
    Vec y = normalized(sub(scale(z, dot(axis, z)), axis));    // image down = -axis, made orthogonal to z
    const Vec x = cross(y, z);
    Camera c;
    c.width = spec.width;
    c.height = spec.height;
    c.K = {spec.focal, 0, spec.width / 2.0, 0, spec.focal, spec.height / 2.0, 0, 0, 1};
    c.R = {x[0], x[1], x[2], y[0], y[1], y[2], z[0], z[1], z[2]};
    const Vec t = scale(Vec{dot(x, position), dot(y, position), dot(z, position)}, -1);
    c.t = t;
    cameras.push_back(c);
  }
  return cameras;
}

}  // namespace handscs
