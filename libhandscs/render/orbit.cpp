#include "render/orbit.h"

#include <cmath>

#include "core/error.h"
#include "core/vec3.h"

namespace handscs {

std::vector<Camera> orbit_cameras(const Vec3& centre, const Vec3& axis_in, double extent,
                                  const OrbitSpec& spec) {
  require(spec.count >= 1, "--orbit: at least one view");
  require(dot(axis_in, axis_in) > 0, "orbit: the hand's long axis has zero length");
  const Vec3 axis = normalized(axis_in);
  // Two directions perpendicular to the axis.
  const Vec3 helper = std::fabs(axis[0]) < 0.9 ? Vec3{1, 0, 0} : Vec3{0, 1, 0};
  const Vec3 e1 = normalized(cross(axis, helper));
  const Vec3 e2 = cross(axis, e1);
  const double distance = spec.focal * extent / (spec.fill * std::min(spec.width, spec.height));
  std::vector<Camera> cameras;
  for (int k = 0; k < spec.count; ++k) {
    const double phi = 2 * M_PI * k / spec.count;
    const Vec3 around = e1 * std::cos(phi) + e2 * std::sin(phi);
    const Vec3 dir = around * std::cos(spec.elevation) + axis * std::sin(spec.elevation);
    const Vec3 position = centre + dir * distance;
    const Vec3 z = normalized(centre - position);  // forward
    Vec3 y = normalized(z * dot(axis, z) - axis);  // image down = -axis, made orthogonal to z
    const Vec3 x = cross(y, z);
    Camera c;
    c.width = spec.width;
    c.height = spec.height;
    c.K = {spec.focal, 0, spec.width / 2.0, 0, spec.focal, spec.height / 2.0, 0, 0, 1};
    c.R = {x[0], x[1], x[2], y[0], y[1], y[2], z[0], z[1], z[2]};
    const Vec3 t = Vec3{dot(x, position), dot(y, position), dot(z, position)} * -1;
    c.t = t;
    cameras.push_back(c);
  }
  return cameras;
}

}  // namespace handscs
