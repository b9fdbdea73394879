#include "synth/forearm.h"

#include <algorithm>
#include <cmath>

namespace handscs {

using namespace synth;

namespace {

// Length out of the frame (m): at ~1 m from 1265 px cameras an image spans ~0.27 m.
constexpr double kLength = 0.3;
// The forearm starts this far inside the hand's wrist end (m), so no gap opens when the wrist bends.
constexpr double kOverlap = 0.012;
// Vertices whose long-axis coordinate lies within this distance of the hand's wrist end measure
// the cross-section (m).
constexpr double kWristBand = 0.012;
// The forearm widens towards the elbow (ratio of semi-axes at the far end to the wrist's).
constexpr double kFlare = 1.3;
constexpr int kSegments = 32, kRings = 16;

Vec3 row(const torch::Tensor& t, int64_t i) {
  const double* p = t[i].data_ptr<double>();
  return {p[0], p[1], p[2]};
}

}  // namespace

ForearmMesh make_forearm(const Rig& rig, const HandAxes& axes) {
  const torch::Tensor vt = rig.v_template.to(torch::kFloat64).contiguous();
  const torch::Tensor joints = torch::matmul(rig.j_regressor.to(torch::kFloat64), vt).contiguous();
  ForearmMesh mesh;
  mesh.pivot = row(joints, 0);
  const Vec3 L = axes.long_axis, N = axes.palm_normal, A = cross(N, L);
  double s_min = 1e9;
  for (int64_t i = 0; i < vt.size(0); ++i) s_min = std::min(s_min, dot(row(vt, i) - mesh.pivot, L));
  // Cross-section of the wrist end: centre and half-extents along A and N.
  Vec3 centre{0, 0, 0};
  double a_lo = 1e9, a_hi = -1e9, n_lo = 1e9, n_hi = -1e9;
  for (int64_t i = 0; i < vt.size(0); ++i) {
    const Vec3 q = row(vt, i) - mesh.pivot;
    if (dot(q, L) > s_min + kWristBand) continue;
    centre = centre + q;
    a_lo = std::min(a_lo, dot(q, A));
    a_hi = std::max(a_hi, dot(q, A));
    n_lo = std::min(n_lo, dot(q, N));
    n_hi = std::max(n_hi, dot(q, N));
  }
  const double ca = 0.5 * (a_lo + a_hi), cn = 0.5 * (n_lo + n_hi);
  const double ra = std::max(0.01, 0.5 * (a_hi - a_lo)), rn = std::max(0.008, 0.5 * (n_hi - n_lo));
  const double s0 = s_min + kOverlap;
  for (int r = 0; r <= kRings; ++r) {
    const double t = static_cast<double>(r) / kRings;
    const double s = s0 - t * kLength, grow = 1 + (kFlare - 1) * t;
    for (int k = 0; k < kSegments; ++k) {
      const double phi = 2 * M_PI * k / kSegments;
      const Vec3 p = mesh.pivot + L * s + A * (ca + ra * grow * std::cos(phi)) +
                     N * (cn + rn * grow * std::sin(phi));
      for (int d = 0; d < 3; ++d) mesh.rest.push_back(static_cast<float>(p[d]));
    }
  }
  // Quads between rings, wound so the normal points outwards (checked against the axis below).
  for (int r = 0; r < kRings; ++r)
    for (int k = 0; k < kSegments; ++k) {
      const int64_t a = r * kSegments + k, b = r * kSegments + (k + 1) % kSegments;
      const int64_t c = a + kSegments, d = b + kSegments;
      for (int64_t id : {a, b, c, b, d, c}) mesh.faces.push_back(id);
    }
  // Fix the winding: the first face's normal must point away from the axis.
  const Vec3 p0 = {mesh.rest[0], mesh.rest[1], mesh.rest[2]};
  const auto at = [&](int64_t i) {
    return Vec3{mesh.rest[i * 3], mesh.rest[i * 3 + 1], mesh.rest[i * 3 + 2]};
  };
  const Vec3 n0 = cross(at(mesh.faces[1]) - p0, at(mesh.faces[2]) - p0);
  const Vec3 axis_point = mesh.pivot + L * s0 + A * ca + N * cn;
  if (dot(n0, p0 - axis_point) < 0)
    for (size_t f = 0; f < mesh.faces.size(); f += 3) std::swap(mesh.faces[f + 1], mesh.faces[f + 2]);
  return mesh;
}

std::vector<float> pose_forearm(const ForearmMesh& forearm, const HandAxes& axes,
                                const HandArticulation& articulation, const Vec3& wrist_world) {
  const Mat3 R = rotation(axes.long_axis, articulation.pronation);
  std::vector<float> out(forearm.rest.size());
  for (size_t i = 0; i < forearm.rest.size() / 3; ++i) {
    const Vec3 x = {forearm.rest[i * 3], forearm.rest[i * 3 + 1], forearm.rest[i * 3 + 2]};
    const Vec3 y = mul(R, x - forearm.pivot) + wrist_world;
    for (int d = 0; d < 3; ++d) out[i * 3 + d] = static_cast<float>(y[d]);
  }
  return out;
}

}  // namespace handscs
