#include "synth/shadows.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace handscs {

using namespace synth;

namespace {

// Rays start this far off the surface (m): past the rounding of float vertices, well below the
// 1-2 mm detail of the geometry.
constexpr double kLift = 3e-4;
// Moller-Trumbore's parallel-ray threshold.
constexpr double kParallel = 1e-12;

struct Triangle {
  Vec3 a, e1, e2;
  double u0, u1, v0, v1, w1;  // bounds in light space (u, v across the light, w towards it)
  int64_t ids[3];
};

bool hits(const Triangle& t, const Vec3& origin, const Vec3& dir) {
  const Vec3 p = cross(dir, t.e2);
  const double det = dot(t.e1, p);
  if (std::fabs(det) < kParallel) return false;
  const double inv = 1.0 / det;
  const Vec3 s = origin - t.a;
  const double u = dot(s, p) * inv;
  if (u < 0 || u > 1) return false;
  const Vec3 q = cross(s, t.e1);
  const double v = dot(dir, q) * inv;
  if (v < 0 || u + v > 1) return false;
  return dot(t.e2, q) * inv > 0;
}

}  // namespace

std::vector<float> light_visibility(const std::vector<float>& vertices,
                                    const std::vector<float>& normals,
                                    const std::vector<int64_t>& faces, const Vec3& light,
                                    double radius_rad, int samples) {
  const size_t num_vertices = vertices.size() / 3, num_faces = faces.size() / 3;
  const Vec3 l = normalized(light);
  const Vec3 helper = std::fabs(l[0]) < 0.9 ? Vec3{1, 0, 0} : Vec3{0, 1, 0};
  const Vec3 bu = normalized(cross(l, helper)), bv = cross(l, bu);
  auto vertex = [&](int64_t i) {
    return Vec3{vertices[i * 3], vertices[i * 3 + 1], vertices[i * 3 + 2]};
  };
  std::vector<Triangle> triangles(num_faces);
  for (size_t f = 0; f < num_faces; ++f) {
    Triangle& t = triangles[f];
    const Vec3 p[3] = {vertex(faces[f * 3]), vertex(faces[f * 3 + 1]), vertex(faces[f * 3 + 2])};
    t.a = p[0];
    t.e1 = p[1] - p[0];
    t.e2 = p[2] - p[0];
    t.u0 = t.v0 = std::numeric_limits<double>::infinity();
    t.u1 = t.v1 = t.w1 = -std::numeric_limits<double>::infinity();
    for (int k = 0; k < 3; ++k) {
      t.ids[k] = faces[f * 3 + k];
      t.u0 = std::min(t.u0, dot(p[k], bu));
      t.u1 = std::max(t.u1, dot(p[k], bu));
      t.v0 = std::min(t.v0, dot(p[k], bv));
      t.v1 = std::max(t.v1, dot(p[k], bv));
      t.w1 = std::max(t.w1, dot(p[k], l));
    }
  }
  // Ray directions: a Fibonacci spiral over the light's disc (deterministic, evenly spread).
  std::vector<Vec3> dirs(samples);
  const double golden = M_PI * (3.0 - std::sqrt(5.0));
  for (int s = 0; s < samples; ++s) {
    const double r = std::tan(radius_rad) * std::sqrt((s + 0.5) / samples);
    const double phi = s * golden;
    dirs[s] = normalized(l + bu * (r * std::cos(phi)) + bv * (r * std::sin(phi)));
  }
  const double slack = std::tan(radius_rad) * 1.001 + 1e-9;
  std::vector<float> visibility(num_vertices, 1.0f);
#pragma omp parallel for schedule(dynamic, 16)
  for (int64_t i = 0; i < static_cast<int64_t>(num_vertices); ++i) {
    const Vec3 n = {normals[i * 3], normals[i * 3 + 1], normals[i * 3 + 2]};
    if (dot(n, l) <= 0) continue;
    const Vec3 origin = vertex(i) + n * kLift;
    const double u = dot(origin, bu), v = dot(origin, bv), w = dot(origin, l);
    std::vector<const Triangle*> near;
    for (const Triangle& t : triangles) {
      if (t.w1 <= w || t.ids[0] == i || t.ids[1] == i || t.ids[2] == i) continue;
      const double reach = slack * (t.w1 - w);
      if (u < t.u0 - reach || u > t.u1 + reach || v < t.v0 - reach || v > t.v1 + reach) continue;
      near.push_back(&t);
    }
    int blocked = 0;
    for (const Vec3& dir : dirs)
      for (const Triangle* t : near)
        if (hits(*t, origin, dir)) {
          ++blocked;
          break;
        }
    visibility[i] = static_cast<float>(1.0 - static_cast<double>(blocked) / samples);
  }
  return visibility;
}

}  // namespace handscs
