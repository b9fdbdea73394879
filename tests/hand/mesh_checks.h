// Mesh checks for the hand tests: edge manifoldness and orientation, triangle areas, generalized
// winding numbers (inside/outside), and triangle-triangle intersections between non-adjacent faces.
#pragma once

#include <ATen/ATen.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <utility>
#include <vector>

namespace handscs::test {

struct MeshData {
  std::vector<std::array<double, 3>> v;
  std::vector<std::array<int64_t, 3>> f;
};

inline MeshData mesh_data(const torch::Tensor& vertices, const torch::Tensor& faces) {
  MeshData m;
  const torch::Tensor vv = vertices.to(torch::kFloat64).contiguous();
  const torch::Tensor ff = faces.to(torch::kInt64).contiguous();
  for (int64_t i = 0; i < vv.size(0); ++i)
    m.v.push_back({vv.data_ptr<double>()[3 * i], vv.data_ptr<double>()[3 * i + 1],
                   vv.data_ptr<double>()[3 * i + 2]});
  for (int64_t i = 0; i < ff.size(0); ++i)
    m.f.push_back({ff.data_ptr<int64_t>()[3 * i], ff.data_ptr<int64_t>()[3 * i + 1],
                   ff.data_ptr<int64_t>()[3 * i + 2]});
  return m;
}

using P3 = std::array<double, 3>;
inline P3 sub(const P3& a, const P3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
inline P3 cross3(const P3& a, const P3& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
inline double dot3(const P3& a, const P3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
inline double norm3(const P3& a) { return std::sqrt(dot3(a, a)); }

struct EdgeReport {
  int64_t edges = 0;
  int64_t not_two_faces = 0;  // undirected edges not shared by exactly two faces
  int64_t inconsistent = 0;   // directed edges used twice (neighbours wound against each other)
};

inline EdgeReport edge_report(const MeshData& m) {
  std::map<std::pair<int64_t, int64_t>, int> directed;
  std::map<std::pair<int64_t, int64_t>, int> undirected;
  for (const auto& f : m.f)
    for (int e = 0; e < 3; ++e) {
      const int64_t a = f[e], b = f[(e + 1) % 3];
      ++directed[{a, b}];
      ++undirected[{std::min(a, b), std::max(a, b)}];
    }
  EdgeReport r;
  r.edges = static_cast<int64_t>(undirected.size());
  for (const auto& [edge, count] : undirected) r.not_two_faces += count != 2;
  for (const auto& [edge, count] : directed) r.inconsistent += count != 1;
  return r;
}

inline double triangle_area(const MeshData& m, size_t i) {
  const auto& f = m.f[i];
  return 0.5 * norm3(cross3(sub(m.v[f[1]], m.v[f[0]]), sub(m.v[f[2]], m.v[f[0]])));
}

// Smallest interior angle of face i (radians).
inline double min_angle(const MeshData& m, size_t i) {
  const auto& f = m.f[i];
  double smallest = 10;
  for (int k = 0; k < 3; ++k) {
    const P3 a = sub(m.v[f[(k + 1) % 3]], m.v[f[k]]), b = sub(m.v[f[(k + 2) % 3]], m.v[f[k]]);
    smallest =
        std::min(smallest, std::acos(std::clamp(dot3(a, b) / (norm3(a) * norm3(b)), -1.0, 1.0)));
  }
  return smallest;
}

inline double signed_volume(const MeshData& m) {
  double volume = 0;
  for (const auto& f : m.f) volume += dot3(m.v[f[0]], cross3(m.v[f[1]], m.v[f[2]])) / 6.0;
  return volume;
}

// Generalized winding number of point q (1 inside a closed outward mesh, 0 outside): the sum of
// signed solid angles of the faces (Van Oosterom and Strackee) over 4 pi.
inline double winding_number(const MeshData& m, const P3& q) {
  double total = 0;
  for (const auto& f : m.f) {
    const P3 a = sub(m.v[f[0]], q), b = sub(m.v[f[1]], q), c = sub(m.v[f[2]], q);
    const double la = norm3(a), lb = norm3(b), lc = norm3(c);
    const double numerator = dot3(a, cross3(b, c));
    const double denominator = la * lb * lc + dot3(a, b) * lc + dot3(b, c) * la + dot3(c, a) * lb;
    total += 2.0 * std::atan2(numerator, denominator);
  }
  return total / (4.0 * M_PI);
}

// Does segment p-q cross triangle (a, b, c)? Strict test: touching and coplanar configurations
// (orientations below 1e-9 of the local length scale cubed, i.e. rounding noise) count as no
// crossing.
inline bool segment_crosses_triangle(const P3& p, const P3& q, const P3& a, const P3& b,
                                     const P3& c) {
  const double scale = std::max({norm3(sub(q, p)), norm3(sub(b, a)), norm3(sub(c, a))});
  const double eps = 1e-9 * scale * scale * scale;
  auto orient = [&](const P3& w, const P3& x, const P3& y, const P3& z) {
    const double o = dot3(sub(x, w), cross3(sub(y, w), sub(z, w)));
    return o > eps ? 1 : o < -eps ? -1 : 0;
  };
  const int sp = orient(a, b, c, p), sq = orient(a, b, c, q);
  if (sp * sq >= 0) return false;
  const int s1 = orient(p, q, a, b), s2 = orient(p, q, b, c), s3 = orient(p, q, c, a);
  return (s1 > 0 && s2 > 0 && s3 > 0) || (s1 < 0 && s2 < 0 && s3 < 0);
}

// Number of pairs of faces sharing no vertex that intersect (sweep over x-sorted bounding boxes).
inline int64_t self_intersections(const MeshData& m) {
  const size_t n = m.f.size();
  std::vector<std::array<double, 6>> box(n);
  for (size_t i = 0; i < n; ++i) {
    std::array<double, 6> b = {1e9, 1e9, 1e9, -1e9, -1e9, -1e9};
    for (int64_t id : m.f[i])
      for (int c = 0; c < 3; ++c) {
        b[c] = std::min(b[c], m.v[id][c]);
        b[c + 3] = std::max(b[c + 3], m.v[id][c]);
      }
    box[i] = b;
  }
  std::vector<size_t> order(n);
  for (size_t i = 0; i < n; ++i) order[i] = i;
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) { return box[a][0] < box[b][0]; });
  int64_t count = 0;
  for (size_t oi = 0; oi < n; ++oi) {
    const size_t i = order[oi];
    for (size_t oj = oi + 1; oj < n && box[order[oj]][0] <= box[i][3]; ++oj) {
      const size_t j = order[oj];
      bool overlap = true;
      for (int c = 1; c < 3; ++c)
        overlap = overlap && box[j][c] <= box[i][c + 3] && box[i][c] <= box[j][c + 3];
      if (!overlap) continue;
      bool shared = false;
      for (int64_t a : m.f[i])
        for (int64_t b : m.f[j]) shared = shared || a == b;
      if (shared) continue;
      bool hit = false;
      for (int e = 0; e < 3 && !hit; ++e) {
        hit = segment_crosses_triangle(m.v[m.f[i][e]], m.v[m.f[i][(e + 1) % 3]], m.v[m.f[j][0]],
                                       m.v[m.f[j][1]], m.v[m.f[j][2]]) ||
              segment_crosses_triangle(m.v[m.f[j][e]], m.v[m.f[j][(e + 1) % 3]], m.v[m.f[i][0]],
                                       m.v[m.f[i][1]], m.v[m.f[i][2]]);
      }
      count += hit;
    }
  }
  return count;
}

}  // namespace handscs::test
