// The built-in procedural hand (see procedural_hand.h): rings of vertices swept along a MANO-like
// skeleton. The palm is a tube of rings from the wrist to the knuckles whose last ring is made of
// the four finger base rings; the gaps between adjacent finger rings are closed by small web
// patches; the thumb tube starts at a hole cut into the palm's radial side; a forearm stub and the
// fingertips end in domes. Joints are ring averages (the regressor), weights are smooth functions
// of the position along each finger, and the shape modes are linear displacement fields.
#include "hand/procedural_hand.h"

#include <ATen/ATen.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <queue>
#include <utility>
#include <vector>

#include "core/vec3.h"
#include "hand/joint_order.h"
#include "hand/rig_mirror.h"

namespace handscs {

namespace {

Vec3 lerp(Vec3 a, Vec3 b, double t) { return a + (b - a) * t; }
double lerp(double a, double b, double t) { return a + (b - a) * t; }
double smoothstep(double x) {
  x = std::clamp(x, 0.0, 1.0);
  return x * x * (3.0 - 2.0 * x);
}
// Component of `v` orthogonal to the unit vector `axis`, normalised.
Vec3 orthogonal(Vec3 v, Vec3 axis) { return normalized(v - axis * dot(v, axis)); }

constexpr double kPi = 3.14159265358979323846;
constexpr int kRingVertices = 16;  // vertices per finger ring (multiple of 4: radial, dorsal, ...)
constexpr std::array<int, 4> kPalmFingers = {kIndex, kMiddle, kRing, kPinky};  // radial to ulnar
constexpr int kPalmRings = 10;  // wrist ring .. knuckle ring
constexpr int kHoleRings = 4;   // thumb hole: 4 rings x 6 columns -> 16 boundary vertices
constexpr int kHoleColumns = 6;

// Region labels (Rig::vertex_labels); documented in docs/RIG_FORMAT.md.
enum Label { kSkin = 0, kNail = 1, kPalmar = 2, kForearm = 3 };
// Ring angle phi (0 radial, pi/2 dorsal): nails cover sin(phi) > 0.45 (about +-63 degrees around
// the dorsal line, the width of a nail on a finger), palmar skin sin(phi) < -0.35 (the pads and the
// palm up to their sides).
constexpr double kNailSin = 0.45;
constexpr double kPalmarSin = -0.35;
// Parts a vertex is built from.
constexpr int kPartPalm = -1;
constexpr int kPartForearm = -2;

struct VertexInfo {
  int part = kPartPalm;  // kPartPalm, kPartForearm or a Finger
  int finger = -1;       // finger of the vertex (fingers) or of its column (palm knuckle side)
  double s = 0;  // fingers: arc length from the finger's base joint; palm: -(distance to knuckles)
  double t = 0;  // palm parameter: 0 at the wrist ring, 1 at the knuckle ring
  Vec3 centre{};  // axis point of the vertex's ring
  bool shared = false;  // on the knuckle ring or the thumb hole (palm and finger meet)
};

struct Mesh {
  std::vector<Vec3> positions;
  std::vector<VertexInfo> info;
  std::vector<int> labels;
  std::vector<std::array<int, 3>> faces;

  int add(Vec3 p, const VertexInfo& vertex_info, int label) {
    positions.push_back(p);
    info.push_back(vertex_info);
    labels.push_back(label);
    return static_cast<int>(positions.size()) - 1;
  }
  // Quad a-b-c-d (cyclic) as two triangles split along the shorter diagonal.
  void quad(int a, int b, int c, int d) {
    if (norm(positions[a] - positions[c]) <= norm(positions[b] - positions[d])) {
      faces.push_back({a, b, c});
      faces.push_back({a, c, d});
    } else {
      faces.push_back({a, b, d});
      faces.push_back({b, c, d});
    }
  }
  // Band of quads between two rings with the same vertex count (cyclic).
  void band(const std::vector<int>& lower, const std::vector<int>& upper) {
    const size_t n = lower.size();
    for (size_t j = 0; j < n; ++j) quad(lower[j], lower[(j + 1) % n], upper[(j + 1) % n], upper[j]);
  }
  void fan(const std::vector<int>& ring, int pole) {
    for (size_t j = 0; j < ring.size(); ++j)
      faces.push_back({ring[j], ring[(j + 1) % ring.size()], pole});
  }
  Vec3 centroid(const std::vector<int>& ids) const {
    Vec3 sum{};
    for (int id : ids) sum = sum + positions[id];
    return sum * (1.0 / static_cast<double>(ids.size()));
  }
  void translate(const std::vector<int>& ids, Vec3 offset) {
    for (int id : ids) positions[id] = positions[id] + offset;
  }
};

// Skeleton of one finger: base joint, two more joints, and the tip's extreme point.
struct Chain {
  std::array<Vec3, 4> points{};
  Vec3 dorsal{};      // direction the nail faces
  double radius = 1;  // scale of the cross-section radii
  double length(int i) const { return norm(points[i + 1] - points[i]); }
  double joint_s(int i) const {  // arc length of points[i] from points[0]
    double s = 0;
    for (int k = 0; k < i; ++k) s += length(k);
    return s;
  }
  double total() const { return joint_s(3); }
  Vec3 point(double s) const {
    for (int k = 0; k < 3; ++k) {
      const double l = length(k);
      if (s <= l || k == 2) return lerp(points[k], points[k + 1], s / l);
      s -= l;
    }
    return points[3];
  }
  // Direction of the chain at s; at a joint, the bisector of the two segments.
  Vec3 direction(double s) const {
    constexpr double kAtJoint = 1e-9;
    for (int k = 0; k < 3; ++k) {
      const double l = length(k);
      const Vec3 d = normalized(points[k + 1] - points[k]);
      if (k < 2 && std::abs(s - l) < kAtJoint)
        return normalized(d + normalized(points[k + 2] - points[k + 1]));
      if (s < l || k == 2) return d;
      s -= l;
    }
    return normalized(points[3] - points[2]);
  }
};

// Cross-section half-axes (radial, dorsal) along a finger: piecewise linear between key stations.
struct Radii {
  std::vector<double> s, radial, dorsal;
  std::pair<double, double> at(double x) const {
    if (x <= s.front()) return {radial.front(), dorsal.front()};
    for (size_t i = 1; i < s.size(); ++i)
      if (x <= s[i]) {
        const double u = (x - s[i - 1]) / (s[i] - s[i - 1]);
        return {lerp(radial[i - 1], radial[i], u), lerp(dorsal[i - 1], dorsal[i], u)};
      }
    return {radial.back(), dorsal.back()};
  }
};

// Angle of `p` around `axis` (through `origin`) in the frame (e_radial, e_dorsal).
double ring_angle(Vec3 p, Vec3 origin, Vec3 e_radial, Vec3 e_dorsal) {
  const Vec3 r = p - origin;
  return std::atan2(dot(r, e_dorsal), dot(r, e_radial));
}

// Unwraps angles along a closed walk: each step is taken as the shortest turn, so a walk around
// the axis ends 2 pi (counter-clockwise) or -2 pi (clockwise) past its start.
std::vector<double> unwrap(std::vector<double> angles) {
  for (size_t i = 1; i < angles.size(); ++i)
    angles[i] = angles[i - 1] + std::remainder(angles[i] - angles[i - 1], 2 * kPi);
  return angles;
}

struct Design {
  Vec3 wrist{};
  std::array<Chain, 5> chains;  // indexed by Finger; chains[kThumb].points[0] is the CMC joint
  std::array<double, 5> knuckle_height;  // dorsal half-axis of each finger's knuckle ring
  std::array<Radii, 5> radii;            // by arc length from the base joint
};

// Thumb cross-sections by arc length from the CMC joint; the tip dome starts 7 mm before the end.
Radii thumb_radii(const Chain& thumb) {
  const double l0 = thumb.length(0), l1 = thumb.length(1), l2 = thumb.length(2);
  return Radii{{0.0, l0, l0 + l1, l0 + l1 + 0.4 * (l2 - 0.007), l0 + l1 + l2 - 0.007},
               {0.0110, 0.0100, 0.0088, 0.0086, 0.0080},
               {0.0100, 0.0090, 0.0076, 0.0072, 0.0066}};
}

// Plausible adult right hand (wrist to middle fingertip about 0.187 m), MANO canonical frame.
Design make_design() {
  Design design;
  design.wrist = {0.095, 0.0, 0.0};
  const Vec3 up{0, 1, 0};
  // index, middle, ring, pinky: knuckle (MCP), splay (degrees towards +z), phalanx lengths
  // (proximal, middle, distal to the tip's extreme), radius scale.
  struct FingerSpec {
    Finger finger;
    Vec3 mcp{};
    double splay_deg;
    double proximal, middle, distal;
    double scale;
  };
  const FingerSpec specs[4] = {
      {kIndex, {0.005, 0.000, 0.027}, 5.0, 0.040, 0.024, 0.021, 1.00},
      {kMiddle, {0.000, 0.000, 0.008}, 0.0, 0.044, 0.027, 0.021, 1.03},
      {kRing, {0.004, -0.001, -0.011}, -5.0, 0.041, 0.026, 0.021, 0.96},
      {kPinky, {0.012, -0.003, -0.028}, -11.0, 0.032, 0.019, 0.019, 0.85},
  };
  for (const FingerSpec& spec : specs) {
    const double a = spec.splay_deg * kPi / 180.0;
    // Fingers point along -x, rotated towards +z by the splay and dipping 2 degrees to the palm.
    const Vec3 d = normalized({-std::cos(a), -0.035, std::sin(a)});
    Chain chain;
    chain.points[0] = spec.mcp;
    chain.points[1] = spec.mcp + d * spec.proximal;
    chain.points[2] = chain.points[1] + d * spec.middle;
    chain.points[3] = chain.points[2] + d * spec.distal;
    chain.dorsal = up;
    chain.radius = spec.scale;
    design.chains[spec.finger] = chain;
    design.knuckle_height[spec.finger] = 0.0110 * spec.scale;
    const double p = spec.proximal, m = spec.middle, t = spec.distal;
    const double f = spec.scale;
    // Knuckle ring (s = 0) is wider than the finger; the tip dome starts 6 mm before the end.
    design.radii[spec.finger] =
        Radii{{0.0, 0.33 * p, p, p + m, p + m + 0.4 * (t - 0.006), p + m + t - 0.006},
              {0.0086 * f, 0.0086 * f, 0.0084 * f, 0.0075 * f, 0.0073 * f, 0.0069 * f},
              {0.0110 * f, 0.0085 * f, 0.0079 * f, 0.0068 * f, 0.0067 * f, 0.0062 * f}};
  }
  Chain thumb;
  thumb.points[0] = {0.072, -0.006, 0.022};  // CMC, inside the thenar
  thumb.points[1] = {0.047, -0.012, 0.050};  // MCP
  thumb.points[2] = {0.027, -0.017, 0.066};  // IP
  thumb.points[3] = thumb.points[2] + normalized(Vec3{-0.85, -0.20, 0.45}) * 0.026;  // tip
  // The thumbnail faces up and away from the palm.
  thumb.dorsal = normalized(Vec3{0.45, 0.75, 0.45});
  thumb.radius = 1.0;
  design.chains[kThumb] = thumb;
  design.knuckle_height[kThumb] = 0;
  design.radii[kThumb] = thumb_radii(thumb);
  return design;
}

// Finger `f`'s ring at arc length s: frame from the chain direction and the finger's dorsal side.
struct RingFrame {
  Vec3 centre{}, axis{}, radial{}, dorsal{};
};
RingFrame ring_frame(const Chain& chain, double s) {
  RingFrame frame;
  frame.centre = chain.point(s);
  frame.axis = chain.direction(s);
  frame.dorsal = orthogonal(chain.dorsal, frame.axis);
  frame.radial = cross(frame.dorsal, frame.axis);
  return frame;
}

struct Builder {
  Design design;
  Mesh mesh;
  std::array<std::vector<int>, kRigJoints> joint_rings;  // vertices averaged into each joint
  std::array<double, kRigJoints> joint_ring_mix{};       // thumb CMC: weight of the second ring
  std::vector<int> thumb_cmc_inner;                      // palm ring mixed into the thumb CMC
  std::array<int, 5> tips{};
  std::array<double, 5>
      base_s{};           // arc length of each tube's first ring (knuckle ring, thumb hole)
  double hole_top_t = 0;  // palm parameter of the thumb hole's distal edge

  // Adds the rings of finger f at `stations` (arc lengths) after the ring `previous`, records the
  // joint rings, and closes the tube with the tip dome and its pole (the tip vertex).
  // `angles_from`/`angles_to`: vertex angles around the axis, blended from the first to the last
  // ring.
  void add_tube(int f, std::vector<int> previous, const std::vector<double>& stations,
                const std::vector<double>& angles_from, const std::vector<double>& angles_to) {
    const Chain& chain = design.chains[f];
    const double cap_start = stations.back();
    for (size_t r = 0; r < stations.size(); ++r) {
      const double s = stations[r];
      const double progress = static_cast<double>(r + 1) / static_cast<double>(stations.size());
      const RingFrame frame = ring_frame(chain, s);
      const auto [radial, dorsal] = design.radii[f].at(s);
      std::vector<int> ring;
      for (int j = 0; j < kRingVertices; ++j) {
        const double phi = lerp(angles_from[j], angles_to[j], progress);
        const Vec3 p = frame.centre + frame.radial * (radial * std::cos(phi)) +
                       frame.dorsal * (dorsal * std::sin(phi));
        ring.push_back(mesh.add(p, {f, f, s, 1.0, frame.centre, false},
                                label_for(f, s, std::sin(phi), chain)));
      }
      for (int k = 1; k < 3; ++k)  // joint rings: centred exactly on the joint
        if (std::abs(s - chain.joint_s(k)) < 1e-12) {
          mesh.translate(ring, chain.points[k] - mesh.centroid(ring));
          joint_rings[kFingerJoints[f][k]] = ring;
        }
      mesh.band(previous, ring);
      previous = ring;
    }
    // Tip dome: an ellipsoid quarter from the last ring to the tip's extreme point.
    const RingFrame base = ring_frame(chain, cap_start);
    const auto [radial, dorsal] = design.radii[f].at(cap_start);
    const double depth = chain.total() - cap_start;
    const double elevations[3] = {30.0, 55.0, 75.0};
    for (double elevation_deg : elevations) {
      const double e = elevation_deg * kPi / 180.0;
      const Vec3 centre = base.centre + base.axis * (depth * std::sin(e));
      std::vector<int> ring;
      for (int j = 0; j < kRingVertices; ++j) {
        const double phi = angles_to[j];
        const Vec3 p = centre + base.radial * (radial * std::cos(e) * std::cos(phi)) +
                       base.dorsal * (dorsal * std::cos(e) * std::sin(phi));
        const double s = cap_start + depth * std::sin(e);
        const int label = (elevation_deg < 60 && std::sin(phi) > kNailSin) ? kNail
                          : std::sin(phi) < kPalmarSin                     ? kPalmar
                                                                           : kSkin;
        ring.push_back(mesh.add(p, {f, f, s, 1.0, base.centre, false}, label));
      }
      mesh.band(previous, ring);
      previous = ring;
    }
    tips[f] = mesh.add(chain.points[3], {f, f, chain.total(), 1.0, base.centre, false}, kSkin);
    mesh.fan(previous, tips[f]);
  }

  int label_for(int f, double s, double sin_phi, const Chain& chain) const {
    const double distal_start = chain.joint_s(2);
    const double nail_start = distal_start + 0.35 * (chain.total() - distal_start);
    if (s >= nail_start && sin_phi > kNailSin) return kNail;
    if (sin_phi < kPalmarSin) return kPalmar;
    return kSkin;
  }
};

// Stations (arc lengths) of a finger's rings after its base ring, ending at the tip dome's start:
// two rings inside each phalanx, one at each joint. The thumb's metacarpal gets its rings from the
// loft instead (with_proximal = false: the first station is the MCP joint).
std::vector<double> tube_stations(const Chain& chain, const Radii& radii, bool with_proximal) {
  const double s1 = chain.joint_s(1), s2 = chain.joint_s(2);
  const double cap = radii.s.back();
  std::vector<double> stations;
  if (with_proximal) stations = {s1 / 3.0, 2.0 * s1 / 3.0};
  for (double s :
       {s1, s1 + (s2 - s1) / 3.0, s1 + 2.0 * (s2 - s1) / 3.0, s2, s2 + 0.5 * (cap - s2), cap})
    stations.push_back(s);
  return stations;
}

// Vertex ids of each palm finger's knuckle ring, indexed by Finger (the thumb's stays empty).
using KnuckleRings = std::array<std::vector<int>, 5>;

// 1. Knuckle rings of the four fingers (uniform angles: their centroid is the MCP joint).
KnuckleRings add_knuckle_rings(Builder& b) {
  const Design& design = b.design;
  Mesh& mesh = b.mesh;
  KnuckleRings knuckle;
  for (int f : kPalmFingers) {
    const Chain& chain = design.chains[f];
    const RingFrame frame = ring_frame(chain, 0.0);
    const double radial = design.radii[f].at(0.0).first;
    for (int k = 0; k < kRingVertices; ++k) {
      const double phi = 2.0 * kPi * k / kRingVertices;
      const Vec3 p = frame.centre + frame.radial * (radial * std::cos(phi)) +
                     frame.dorsal * (design.knuckle_height[f] * std::sin(phi));
      knuckle[f].push_back(mesh.add(p, {f, f, 0.0, 1.0, frame.centre, true},
                                    std::sin(phi) < kPalmarSin ? kPalmar : kSkin));
    }
    b.joint_rings[kFingerJoints[f][0]] = knuckle[f];
  }
  return knuckle;
}

// The palm's knuckle ring, made of the four knuckle rings' vertices: the palm rings' columns.
struct PalmContour {
  std::vector<int> columns;        // vertex ids, in the order of the walk around the palm
  std::vector<int> column_finger;  // finger whose knuckle ring holds each column
  std::vector<double> fraction;    // arc-length position: 0-1 dorsal half, 1-2 palmar half
  Vec3 knuckle_centre{};           // mean of the four MCP joints
};

// Column positions along the knuckle contour: arc-length fractions of the dorsal half (radial
// side -> ulnar side) and of the palmar half (ulnar -> radial). The palm sections place their
// columns at the same fractions of their own halves, so columns never cross.
std::vector<double> contour_fractions(const Mesh& mesh, const std::vector<int>& palm_columns) {
  const int columns = static_cast<int>(palm_columns.size());
  const int ulnar_column = 1 + 4 * (kRingVertices / 2 - 1);  // after index k=0 and 4 dorsal arcs
  std::vector<double> fraction(columns, 0.0);
  std::vector<double> along(columns + 1, 0.0);
  for (int c = 1; c <= columns; ++c)
    along[c] = along[c - 1] + norm(mesh.positions[palm_columns[c % columns]] -
                                   mesh.positions[palm_columns[c - 1]]);
  for (int c = 0; c < columns; ++c)
    fraction[c] = c <= ulnar_column ? along[c] / along[ulnar_column]
                                    : 1.0 + (along[c] - along[ulnar_column]) /
                                                (along[columns] - along[ulnar_column]);
  return fraction;
}

// 2. The knuckle ring of the palm: radial side of the index, the dorsal arcs from index to pinky,
//    the ulnar side of the pinky, the palmar arcs back from pinky to index.
PalmContour knuckle_contour(const Builder& b, const KnuckleRings& knuckle) {
  PalmContour contour;
  std::vector<int>& palm_columns = contour.columns;
  std::vector<int>& column_finger = contour.column_finger;
  palm_columns.push_back(knuckle[kIndex][0]);
  column_finger.push_back(kIndex);
  for (int f : kPalmFingers)
    for (int k = 1; k < kRingVertices / 2; ++k) {
      palm_columns.push_back(knuckle[f][k]);
      column_finger.push_back(f);
    }
  palm_columns.push_back(knuckle[kPinky][kRingVertices / 2]);
  column_finger.push_back(kPinky);
  for (int i = 3; i >= 0; --i)
    for (int k = kRingVertices / 2 + 1; k < kRingVertices; ++k) {
      palm_columns.push_back(knuckle[kPalmFingers[i]][k]);
      column_finger.push_back(kPalmFingers[i]);
    }

  for (int f : kPalmFingers)
    contour.knuckle_centre = contour.knuckle_centre + b.design.chains[f].points[0] * 0.25;
  contour.fraction = contour_fractions(b.mesh, palm_columns);
  return contour;
}

// Palm cross-section at the palm parameter t: a superellipse, between an ellipse (exponent 2) and
// a rectangle, for the rounded-rectangle section of a palm.
constexpr double kSuperellipse = 2.6;
// Half-width (m): 28 mm at the wrist, widening to the knuckles' 38 mm over the palm's first 35%.
double section_width(double t) { return lerp(0.028, 0.038, smoothstep(t / 0.35)); }
// Half-height (m): 16.5 mm at the wrist, thinning to 14 mm at the knuckles.
double section_height(double t) { return lerp(0.0165, 0.0140, t); }
// Superellipse point for angle, unit half-axes.
std::pair<double, double> section_unit(double angle) {
  const double c = std::cos(angle), s = std::sin(angle);
  return std::pair<double, double>{std::copysign(std::pow(std::abs(c), 2.0 / kSuperellipse), c),
                                   std::copysign(std::pow(std::abs(s), 2.0 / kSuperellipse), s)};
}

// Angle on the section at which the arc length reaches `fraction` (0-1 dorsal half, 1-2 palmar).
double section_angle(double t, double f) {
  constexpr int kSamples = 256;
  const double width = section_width(t), height = section_height(t);
  const double start = f <= 1.0 ? 0.0 : kPi;
  const double local = f <= 1.0 ? f : f - 1.0;
  std::vector<double> length(kSamples + 1, 0.0);
  auto point = [&](int i) {
    const auto [u, v] = section_unit(start + kPi * i / kSamples);
    return std::pair<double, double>{width * u, height * v};
  };
  for (int i = 1; i <= kSamples; ++i) {
    const auto [u0, v0] = point(i - 1);
    const auto [u1, v1] = point(i);
    length[i] = length[i - 1] + std::hypot(u1 - u0, v1 - v0);
  }
  const double target = local * length[kSamples];
  int i = 1;
  while (i < kSamples && length[i] < target) ++i;
  const double w = (target - length[i - 1]) / std::max(length[i] - length[i - 1], 1e-30);
  return start + kPi * (i - 1 + std::clamp(w, 0.0, 1.0)) / kSamples;
}

// Point of the section at palm parameter t and `angle`, in the plane at `x`; the section's centre
// moves on the line from the wrist to the knuckle centre.
Vec3 section_point(Vec3 wrist, Vec3 knuckle_centre, double t, double angle, double x) {
  const auto [u, v] = section_unit(angle);
  const Vec3 centre = lerp(wrist, knuckle_centre, t);
  return Vec3{x, centre[1] + section_height(t) * v, centre[2] + section_width(t) * u};
}

// The palm's rings of vertices, one column per knuckle contour vertex.
struct Palm {
  std::vector<std::vector<int>> rings;  // kPalmRings rings: wrist ring .. knuckle ring
  std::vector<double> theta;  // column angles on the mid-palm section (thumb hole, labels)
};

// 3. Palm rings from the wrist (t = 0) to the knuckles (t = 1): a rounded-rectangle section
//    (superellipse exponent 2.6) widening from the wrist, morphing into the knuckle ring.
Palm add_palm_rings(Builder& b, const PalmContour& contour) {
  const Design& design = b.design;
  Mesh& mesh = b.mesh;
  const std::vector<int>& palm_columns = contour.columns;
  const int columns = static_cast<int>(palm_columns.size());
  Palm palm;
  for (int c = 0; c < columns; ++c) palm.theta.push_back(section_angle(0.4, contour.fraction[c]));
  palm.rings.resize(kPalmRings);
  palm.rings[kPalmRings - 1] = palm_columns;
  for (int r = 0; r + 1 < kPalmRings; ++r) {
    const double t = static_cast<double>(r) / (kPalmRings - 1);
    const Vec3 centre = lerp(design.wrist, contour.knuckle_centre, t);
    for (int c = 0; c < columns; ++c) {
      const Vec3 knuckle_point = mesh.positions[palm_columns[c]];
      const double x = lerp(design.wrist[0], knuckle_point[0], t);
      // The cross-section morphs into the knuckle ring; x keeps the ring spacing.
      const Vec3 on_section = section_point(design.wrist, contour.knuckle_centre, t,
                                            section_angle(t, contour.fraction[c]), x);
      Vec3 p = lerp(on_section, knuckle_point, smoothstep((t - 0.5) / 0.5));
      p[0] = x;
      VertexInfo info{kPartPalm, contour.column_finger[c], -(x - knuckle_point[0]), t, centre,
                      false};
      palm.rings[r].push_back(
          mesh.add(p, info, std::sin(palm.theta[c]) < kPalmarSin ? kPalmar : kSkin));
    }
  }
  // The wrist joint is the wrist ring's centroid: centre the ring on the designed wrist.
  mesh.translate(palm.rings[0], design.wrist - mesh.centroid(palm.rings[0]));
  b.joint_rings[0] = palm.rings[0];
  return palm;
}

// The block of palm quads left out for the thumb, and its boundary.
struct ThumbHole {
  int column = 0;         // first column of the block (cyclic)
  int ring = 1;           // first palm ring of the block
  std::vector<int> walk;  // boundary walk: bottom row, far column, top row back, near column down
};

// First column of the hole: the block whose middle faces the thumb's metacarpal axis on the
// mid-palm section.
int thumb_hole_column(const std::vector<double>& theta, const Chain& thumb) {
  const int columns = static_cast<int>(theta.size());
  const Vec3 thumb_axis = normalized(thumb.points[1] - thumb.points[0]);
  const double target_angle = std::atan2(thumb_axis[1], thumb_axis[2]);
  int hole_column = 0;
  double best = 1e9;
  for (int c = 0; c < columns; ++c) {
    const double a = theta[(c + kHoleColumns / 2 - 1) % columns];
    const double a2 = theta[(c + kHoleColumns / 2) % columns];
    const double mid = std::atan2(std::sin(a) + std::sin(a2), std::cos(a) + std::cos(a2));
    const double diff = std::abs(std::remainder(mid - target_angle, 2 * kPi));
    if (diff < best) {
      best = diff;
      hole_column = c;
    }
  }
  return hole_column;
}

// First ring of the hole: the block whose middle (along x) is nearest the metacarpal's exit.
int thumb_hole_ring(const Mesh& mesh, const Palm& palm, int hole_column, Vec3 knuckle_centre,
                    const Chain& thumb) {
  int hole_ring = 1;
  // Where the metacarpal axis reaches the palm's radial side (z = knuckle half-width).
  const double side_z = knuckle_centre[2] + 0.038;
  const double along = (side_z - thumb.points[0][2]) / (thumb.points[1][2] - thumb.points[0][2]);
  const double exit_x = lerp(thumb.points[0][0], thumb.points[1][0], along);
  double best = 1e9;
  for (int r = 1; r + kHoleRings < kPalmRings - 1; ++r) {
    const double mid_x = 0.5 * (mesh.positions[palm.rings[r][hole_column]][0] +
                                mesh.positions[palm.rings[r + kHoleRings - 1][hole_column]][0]);
    if (std::abs(mid_x - exit_x) < best) {
      best = std::abs(mid_x - exit_x);
      hole_ring = r;
    }
  }
  return hole_ring;
}

// The palm's quads between consecutive rings, except the hole's block.
void add_palm_quads(Mesh& mesh, const Palm& palm, const ThumbHole& hole) {
  const int columns = static_cast<int>(palm.theta.size());
  auto in_hole = [&](int r, int c) {  // quad (r, c) -> (r + 1, c + 1) removed
    const int dc = (c - hole.column + columns) % columns;
    return r >= hole.ring && r < hole.ring + kHoleRings - 1 && dc < kHoleColumns - 1;
  };
  for (int r = 0; r + 1 < kPalmRings; ++r)
    for (int c = 0; c < columns; ++c) {
      if (in_hole(r, c)) continue;
      const int c1 = (c + 1) % columns;
      mesh.quad(palm.rings[r][c], palm.rings[r][c1], palm.rings[r + 1][c1], palm.rings[r + 1][c]);
    }
}

// The hole's boundary walk (ThumbHole::walk) around the block at `hole.column`, `hole.ring`.
std::vector<int> thumb_hole_walk(const Palm& palm, const ThumbHole& hole) {
  const int columns = static_cast<int>(palm.theta.size());
  const auto& rings = palm.rings;
  std::vector<int> walk;
  auto column = [&](int i) { return (hole.column + i) % columns; };
  for (int i = 0; i < kHoleColumns; ++i) walk.push_back(rings[hole.ring][column(i)]);
  for (int r = 1; r < kHoleRings; ++r)
    walk.push_back(rings[hole.ring + r][column(kHoleColumns - 1)]);
  for (int i = kHoleColumns - 2; i >= 0; --i)
    walk.push_back(rings[hole.ring + kHoleRings - 1][column(i)]);
  for (int r = kHoleRings - 2; r >= 1; --r) walk.push_back(rings[hole.ring + r][column(0)]);
  return walk;
}

// 4. Thumb hole: a block of (kHoleRings - 1) x (kHoleColumns - 1) palm quads on the radial side
//    where the thumb's metacarpal axis leaves the palm.
ThumbHole cut_thumb_hole(Builder& b, const Palm& palm, const PalmContour& contour) {
  const Chain& thumb = b.design.chains[kThumb];
  ThumbHole hole;
  hole.column = thumb_hole_column(palm.theta, thumb);
  hole.ring = thumb_hole_ring(b.mesh, palm, hole.column, contour.knuckle_centre, thumb);
  add_palm_quads(b.mesh, palm, hole);
  hole.walk = thumb_hole_walk(palm, hole);
  b.hole_top_t = static_cast<double>(hole.ring + kHoleRings - 1) / (kPalmRings - 1);
  for (int id : hole.walk) {
    b.mesh.info[id].shared = true;
    b.mesh.info[id].finger = kThumb;
  }
  return hole;
}

// 5. Webs between adjacent fingers: the hexagon (dorsal end, side, palmar start of one finger,
//    palmar end, side, dorsal start of the next) in four triangles.
void add_webs(Mesh& mesh, const KnuckleRings& knuckle) {
  for (int i = 0; i < 3; ++i) {
    const auto& a = knuckle[kPalmFingers[i]];
    const auto& n = knuckle[kPalmFingers[i + 1]];
    const int A = a[kRingVertices / 2 - 1], B = a[kRingVertices / 2], C = a[kRingVertices / 2 + 1];
    const int D = n[kRingVertices - 1], E = n[0], F = n[1];
    mesh.faces.push_back({A, B, F});
    mesh.faces.push_back({B, E, F});
    mesh.faces.push_back({B, C, E});
    mesh.faces.push_back({C, D, E});
  }
}

// 6. Forearm stub behind the wrist ring, closed by a shallow dome.
void add_forearm(Mesh& mesh, const Design& design, const std::vector<int>& wrist_ring,
                 Vec3 knuckle_centre) {
  const int columns = static_cast<int>(wrist_ring.size());
  std::vector<int> previous = wrist_ring;
  const Vec3 axis = normalized(design.wrist - knuckle_centre);  // towards the elbow
  const double offsets[2] = {0.012, 0.022};
  for (double offset : offsets) {
    std::vector<int> ring;
    for (int c = 0; c < columns; ++c) {
      const Vec3 p = mesh.positions[wrist_ring[c]] + axis * offset;
      ring.push_back(
          mesh.add(p, {kPartForearm, -1, 0.0, 0.0, design.wrist + axis * offset, false}, kForearm));
    }
    mesh.band(previous, ring);
    previous = ring;
  }
  const Vec3 base = design.wrist + axis * 0.022;
  const double depth = 0.010;
  const double elevations[2] = {35.0, 65.0};
  for (double elevation_deg : elevations) {
    const double e = elevation_deg * kPi / 180.0;
    std::vector<int> ring;
    for (int c = 0; c < columns; ++c) {
      const Vec3 rim = mesh.positions[wrist_ring[c]] + axis * 0.022;
      const Vec3 p = base + (rim - base) * std::cos(e) + axis * (depth * std::sin(e));
      ring.push_back(mesh.add(p, {kPartForearm, -1, 0.0, 0.0, base, false}, kForearm));
    }
    mesh.band(previous, ring);
    previous = ring;
  }
  const int pole =
      mesh.add(base + axis * depth, {kPartForearm, -1, 0.0, 0.0, base, false}, kForearm);
  mesh.fan(previous, pole);
}

// 7. Finger tubes from their knuckle rings.
void add_finger_tubes(Builder& b, const KnuckleRings& knuckle) {
  for (int f : kPalmFingers) {
    std::vector<double> uniform;
    for (int k = 0; k < kRingVertices; ++k) uniform.push_back(2.0 * kPi * k / kRingVertices);
    const std::vector<double> stations = tube_stations(b.design.chains[f], b.design.radii[f], true);
    b.base_s[f] = 0.0;
    b.add_tube(f, knuckle[f], stations, uniform, uniform);
  }
}

// The thumb's CMC joint: the hole's centroid mixed with the centroid of the palm ring nearest to
// the designed joint (along x); moves the thumb chain's base there and records the joint's rings.
// Returns that palm ring's centroid.
Vec3 place_thumb_cmc(Builder& b, const Palm& palm, const ThumbHole& hole, Vec3 hole_centre) {
  const Mesh& mesh = b.mesh;
  const Chain& thumb = b.design.chains[kThumb];
  int inner_ring = hole.ring;
  for (int r = 0; r < kPalmRings - 1; ++r)
    if (std::abs(mesh.positions[palm.rings[r][0]][0] - thumb.points[0][0]) <
        std::abs(mesh.positions[palm.rings[inner_ring][0]][0] - thumb.points[0][0]))
      inner_ring = r;
  const Vec3 inner_centre = mesh.centroid(palm.rings[inner_ring]);
  const Vec3 span = inner_centre - hole_centre;
  const double mix =
      std::clamp(dot(thumb.points[0] - hole_centre, span) / dot(span, span), 0.0, 1.0);
  b.design.chains[kThumb].points[0] = lerp(hole_centre, inner_centre, mix);
  b.design.radii[kThumb] = thumb_radii(b.design.chains[kThumb]);
  b.joint_rings[13] = hole.walk;
  b.thumb_cmc_inner = palm.rings[inner_ring];
  b.joint_ring_mix[13] = mix;
  return inner_centre;
}

// Angles of the walk's vertices around the chain's base in the frame of `frame`, unwrapped.
std::vector<double> walk_angles(const Mesh& mesh, const std::vector<int>& walk, const Chain& chain,
                                const RingFrame& frame) {
  std::vector<double> angles;
  for (int id : walk)
    angles.push_back(ring_angle(mesh.positions[id], chain.points[0], frame.radial, frame.dorsal));
  return unwrap(angles);
}

// Lofted rings from the hole to the MCP ring's shape: quadratic Bezier curves that leave the
// palm along its outward normal (so the thumb's base stands clear of the palm) and arrive
// along the metacarpal. Returns the last ring.
std::vector<int> add_thumb_loft(Builder& b, const std::vector<int>& hole, double s_hole,
                                Vec3 hole_normal, const std::vector<double>& uniform,
                                const RingFrame& mcp_frame) {
  Mesh& mesh = b.mesh;
  const Chain& chain = b.design.chains[kThumb];
  const double s_mcp = chain.joint_s(1);
  const auto [mcp_radial, mcp_dorsal] = b.design.radii[kThumb].at(s_mcp);
  constexpr double kLoftLift = 0.008;  // metres: Bezier control point above the hole
  std::vector<int> previous = hole;
  for (double a : {1.0 / 3.0, 2.0 / 3.0}) {
    const double s = lerp(s_hole, s_mcp, a);
    const Vec3 centre = chain.point(s);
    std::vector<int> ring;
    for (int j = 0; j < kRingVertices; ++j) {
      const double phi = uniform[j];
      const Vec3 start = mesh.positions[hole[j]];
      const Vec3 target = chain.point(s_mcp) + mcp_frame.radial * (mcp_radial * std::cos(phi)) +
                          mcp_frame.dorsal * (mcp_dorsal * std::sin(phi));
      const Vec3 control = start + hole_normal * kLoftLift;
      const Vec3 p = start * ((1 - a) * (1 - a)) + control * (2 * a * (1 - a)) + target * (a * a);
      ring.push_back(mesh.add(p, {kThumb, kThumb, s, 1.0, centre, false},
                              std::sin(phi) < kPalmarSin ? kPalmar : kSkin));
    }
    mesh.band(previous, ring);
    previous = ring;
  }
  return previous;
}

// 8. Thumb: the CMC joint mixes the hole's centroid with the palm ring's centroid nearest to the
//    designed joint; lofted rings lead from the hole to the MCP ring; then a finger tube.
void add_thumb(Builder& b, const Palm& palm, ThumbHole hole) {
  Mesh& mesh = b.mesh;
  const Vec3 hole_centre = mesh.centroid(hole.walk);
  const Vec3 inner_centre = place_thumb_cmc(b, palm, hole, hole_centre);

  const Chain& chain = b.design.chains[kThumb];
  const Vec3 axis = normalized(chain.points[1] - chain.points[0]);
  const RingFrame mcp_frame = ring_frame(chain, chain.joint_s(1));
  // Angles of the hole's vertices around the metacarpal axis; the walk must turn like a ring.
  std::vector<double> angles = walk_angles(mesh, hole.walk, chain, mcp_frame);
  if (angles.back() < angles.front()) {  // the walk turns clockwise: reverse it
    std::reverse(hole.walk.begin() + 1, hole.walk.end());
    angles = walk_angles(mesh, hole.walk, chain, mcp_frame);
  }
  double offset = 0;
  for (int j = 0; j < kRingVertices; ++j)
    offset += (angles[j] - 2.0 * kPi * j / kRingVertices) / kRingVertices;
  std::vector<double> uniform;
  for (int j = 0; j < kRingVertices; ++j) uniform.push_back(offset + 2.0 * kPi * j / kRingVertices);
  const double s_hole = dot(hole_centre - chain.points[0], axis);
  b.base_s[kThumb] = s_hole;
  for (int id : hole.walk) mesh.info[id].s = dot(mesh.positions[id] - chain.points[0], axis);

  const Vec3 hole_normal = orthogonal(hole_centre - inner_centre, Vec3{1, 0, 0});
  const std::vector<int> last_loft_ring =
      add_thumb_loft(b, hole.walk, s_hole, hole_normal, uniform, mcp_frame);
  const std::vector<double> stations = tube_stations(chain, b.design.radii[kThumb], false);
  b.add_tube(kThumb, last_loft_ring, stations, uniform, uniform);
}

// Builds the skin: knuckle rings, palm, thumb hole, webs, forearm stub, finger and thumb tubes.
void build_mesh(Builder& b) {
  const KnuckleRings knuckle = add_knuckle_rings(b);
  const PalmContour contour = knuckle_contour(b, knuckle);
  const Palm palm = add_palm_rings(b, contour);
  ThumbHole hole = cut_thumb_hole(b, palm, contour);
  add_webs(b.mesh, knuckle);
  add_forearm(b.mesh, b.design, palm.rings[0], contour.knuckle_centre);
  add_finger_tubes(b, knuckle);
  add_thumb(b, palm, std::move(hole));
}

// Drops vertices no face uses (the thumb hole's interior) and renumbers everything.
void drop_unused_vertices(Builder& b) {
  Mesh& mesh = b.mesh;
  const int num_all = static_cast<int>(mesh.positions.size());
  std::vector<int> used(num_all, 0);
  for (const auto& f : mesh.faces)
    for (int v : f) used[v] = 1;
  std::vector<int> remap(num_all, -1);
  int num_vertices = 0;
  for (int v = 0; v < num_all; ++v)
    if (used[v]) remap[v] = num_vertices++;
  auto remap_list = [&](std::vector<int>& ids) {
    for (int& id : ids) id = remap[id];
  };
  Mesh compact;
  for (int v = 0; v < num_all; ++v)
    if (used[v]) compact.add(mesh.positions[v], mesh.info[v], mesh.labels[v]);
  for (auto f : mesh.faces) compact.faces.push_back({remap[f[0]], remap[f[1]], remap[f[2]]});
  for (auto& ring : b.joint_rings) remap_list(ring);
  remap_list(b.thumb_cmc_inner);
  for (int& tip : b.tips) tip = remap[tip];
  mesh = std::move(compact);
}

// Orients faces consistently by propagation across shared edges, then outwards (positive volume).
void orient_outwards(Mesh& mesh) {
  const size_t num_faces = mesh.faces.size();
  std::map<std::pair<int, int>, std::vector<size_t>> edge_faces;
  for (size_t i = 0; i < num_faces; ++i)
    for (int e = 0; e < 3; ++e) {
      const int a = mesh.faces[i][e], c = mesh.faces[i][(e + 1) % 3];
      edge_faces[{std::min(a, c), std::max(a, c)}].push_back(i);
    }
  auto has_directed = [&](size_t i, int a, int c) {
    for (int e = 0; e < 3; ++e)
      if (mesh.faces[i][e] == a && mesh.faces[i][(e + 1) % 3] == c) return true;
    return false;
  };
  std::vector<int> done(num_faces, 0);
  for (size_t seed = 0; seed < num_faces; ++seed) {
    if (done[seed]) continue;
    done[seed] = 1;
    std::queue<size_t> queue;
    queue.push(seed);
    while (!queue.empty()) {
      const size_t i = queue.front();
      queue.pop();
      for (int e = 0; e < 3; ++e) {
        const int a = mesh.faces[i][e], c = mesh.faces[i][(e + 1) % 3];
        for (size_t j : edge_faces[{std::min(a, c), std::max(a, c)}]) {
          if (done[j]) continue;
          // A consistently oriented neighbour runs the shared edge the other way.
          if (has_directed(j, a, c)) std::swap(mesh.faces[j][1], mesh.faces[j][2]);
          done[j] = 1;
          queue.push(j);
        }
      }
    }
  }
  double volume = 0;
  for (const auto& f : mesh.faces)
    volume += dot(mesh.positions[f[0]], cross(mesh.positions[f[1]], mesh.positions[f[2]])) / 6.0;
  if (volume < 0)
    for (auto& f : mesh.faces) std::swap(f[1], f[2]);
}

// Joint regressor [16, V] (row-major): ring averages (thumb CMC: hole ring mixed with a palm ring).
std::vector<double> joint_regressor(const Builder& b) {
  const int64_t V = static_cast<int64_t>(b.mesh.positions.size());
  std::vector<double> regressor(static_cast<size_t>(kRigJoints * V), 0.0);
  for (int k = 0; k < kRigJoints; ++k) {
    const double mix = (k == 13) ? b.joint_ring_mix[13] : 0.0;
    for (int id : b.joint_rings[k]) regressor[k * V + id] += (1.0 - mix) / b.joint_rings[k].size();
    if (k == 13)
      for (int id : b.thumb_cmc_inner) regressor[k * V + id] += mix / b.thumb_cmc_inner.size();
  }
  return regressor;
}

std::array<Vec3, kRigJoints> regressed_joints(const Mesh& mesh,
                                              const std::vector<double>& regressor) {
  const int64_t V = static_cast<int64_t>(mesh.positions.size());
  std::array<Vec3, kRigJoints> joints;
  for (int k = 0; k < kRigJoints; ++k) {
    Vec3 j{};
    for (int64_t v = 0; v < V; ++v) j = j + mesh.positions[v] * regressor[k * V + v];
    joints[k] = j;
  }
  return joints;
}

// Skinning weights [V, 16]: smoothsteps along each finger (wrist -> base -> middle -> distal
// joint), then a few smoothing passes over the palm so the knuckle region blends across columns.
std::vector<double> skinning_weights(const Builder& b) {
  const Mesh& mesh = b.mesh;
  const Design& design = b.design;
  const int64_t V = static_cast<int64_t>(mesh.positions.size());
  std::vector<double> weights(static_cast<size_t>(V * kRigJoints), 0.0);
  for (int64_t v = 0; v < V; ++v) {
    const VertexInfo& info = mesh.info[v];
    double* w = &weights[v * kRigJoints];
    if (info.part == kPartForearm || info.finger < 0) {
      w[0] = 1.0;
      continue;
    }
    const int f = info.finger;
    const Chain& chain = design.chains[f];
    // Blend centres: the base ring, then the two joints; half-widths: half the shorter
    // neighbouring segment, so adjacent blend zones never overlap.
    const double s0 = b.base_s[f], s1 = chain.joint_s(1), s2 = chain.joint_s(2);
    const double h0 = (f == kThumb) ? 0.5 * (s1 - s0) : 0.012;
    const double h1 = 0.5 * std::min(s1 - s0, s2 - s1);
    const double h2 = 0.5 * std::min(s2 - s1, chain.total() - s2);
    double s = info.s;
    if (f == kThumb && info.part == kPartPalm)  // thumb hole ring: half palm, half thumb
      s = s0;
    const double b0 = smoothstep((s - s0 + h0) / (2 * h0));
    const double b1 = smoothstep((s - s1 + h1) / (2 * h1));
    const double b2 = smoothstep((s - s2 + h2) / (2 * h2));
    w[0] = 1.0 - b0;
    w[kFingerJoints[f][0]] = b0 - b1;
    w[kFingerJoints[f][1]] = b1 - b2;
    w[kFingerJoints[f][2]] = b2;
  }
  {
    // Neighbours for the palm smoothing (palm vertices not on a shared ring).
    std::vector<std::vector<int>> neighbours(V);
    for (const auto& f : mesh.faces)
      for (int e = 0; e < 3; ++e) {
        neighbours[f[e]].push_back(f[(e + 1) % 3]);
        neighbours[f[e]].push_back(f[(e + 2) % 3]);
      }
    constexpr int kSmoothingPasses = 4;
    for (int pass = 0; pass < kSmoothingPasses; ++pass) {
      std::vector<double> next = weights;
      for (int64_t v = 0; v < V; ++v) {
        if (mesh.info[v].part != kPartPalm || mesh.info[v].shared) continue;
        for (int k = 0; k < kRigJoints; ++k) {
          double sum = 0;
          for (int n : neighbours[v]) sum += weights[n * kRigJoints + k];
          next[v * kRigJoints + k] =
              0.5 * weights[v * kRigJoints + k] + 0.5 * sum / neighbours[v].size();
        }
      }
      weights.swap(next);
    }
    for (int64_t v = 0; v < V; ++v) {
      double sum = 0;
      for (int k = 0; k < kRigJoints; ++k) {
        double& w = weights[v * kRigJoints + k];
        if (w < 1e-12) w = 0;  // exact zeros: untouched joints must not move the vertex
        sum += w;
      }
      for (int k = 0; k < kRigJoints; ++k) weights[v * kRigJoints + k] /= sum;
    }
  }
  return weights;
}

// Shape modes [V, 3, 10] per unit beta: size, finger length, palm width, thickness, finger girth,
// palm length, thumb length; beta 7-9 are zero.
std::vector<double> shape_modes(const Builder& b, const std::array<Vec3, kRigJoints>& joints) {
  const Mesh& mesh = b.mesh;
  const Design& design = b.design;
  const int64_t V = static_cast<int64_t>(mesh.positions.size());
  std::vector<double> shapedirs(static_cast<size_t>(V * 3 * kShapeDim), 0.0);
  {
    const Vec3 wrist = joints[0];
    Vec3 knuckles{};
    for (int f : kPalmFingers) knuckles = knuckles + joints[kFingerJoints[f][0]] * 0.25;
    const Vec3 hole_centre = joints[13];
    const double palm_mid_z = knuckles[2];
    auto set = [&](int64_t v, int mode, Vec3 d) {
      shapedirs[(v * 3 + 0) * kShapeDim + mode] = d[0];
      shapedirs[(v * 3 + 1) * kShapeDim + mode] = d[1];
      shapedirs[(v * 3 + 2) * kShapeDim + mode] = d[2];
    };
    for (int64_t v = 0; v < V; ++v) {
      const VertexInfo& info = mesh.info[v];
      const Vec3 p = mesh.positions[v];
      const bool finger = info.part >= 0 || info.shared;
      const int f = info.finger;
      const Vec3 base = f >= 0 ? joints[kFingerJoints[f][0]] : wrist;
      // 0: overall size, 4 % per unit about the wrist.
      set(v, 0, (p - wrist) * 0.04);
      // 1: finger length (index..pinky), 6 % per unit: rings slide along the chain.
      if (finger && f != kThumb && !info.shared) set(v, 1, (info.centre - base) * 0.06);
      // 2: palm width, 5 % per unit: fingers move with their knuckle, the palm stretches.
      double z_ref = p[2];
      if (info.part >= 0 && f != kThumb) z_ref = base[2];
      if (info.part == kThumb) z_ref = hole_centre[2];
      if (info.part == kPartPalm && f >= 0 && f != kThumb)
        z_ref = lerp(p[2], base[2], smoothstep(info.t));
      set(v, 2, Vec3{0, 0, 0.05 * (z_ref - palm_mid_z)});
      // 3: thickness, 6 % per unit, about each ring's centre.
      set(v, 3, Vec3{0, 0.06 * (p[1] - info.centre[1]), 0});
      // 4: finger girth, 6 % per unit about the ring axis, fading in from the base ring.
      if (info.part >= 0 && !info.shared) {
        const double fade = smoothstep((info.s - b.base_s[f]) / 0.01);
        set(v, 4, (p - info.centre) * (0.06 * fade));
      }
      // 5: palm length, 5 % of the wrist-knuckle distance per unit: the palm stretches between
      //    the thumb's base and the knuckles (wrist, thumb and forearm stay).
      const Vec3 palm_vector = (knuckles - wrist) * 0.05;
      if (info.part == kPartPalm)
        set(v, 5, palm_vector * smoothstep((info.t - b.hole_top_t) / (1.0 - b.hole_top_t)));
      if (info.part >= 0 && f != kThumb) set(v, 5, palm_vector);
      // 6: thumb length, 7 % per unit of the distance from the thumb's base (the hole).
      if (info.part == kThumb)
        set(v, 6, (info.centre - design.chains[kThumb].point(b.base_s[kThumb])) * 0.07);
    }
  }
  return shapedirs;
}

// Relaxed hand (hands_mean [45]): each finger curls about its flexion axis (towards the palm), a
// little more from index to pinky; the thumb bends slightly towards the palm.
std::vector<double> relaxed_pose(const Builder& b, const std::array<Vec3, kRigJoints>& joints) {
  std::vector<double> hands_mean(kPoseDim - 3, 0.0);
  {
    const Vec3 palm_normal{0, -1, 0};
    const double curl[5][3] = {{0.10, 0.15, 0.10},   // thumb
                               {0.15, 0.25, 0.12},   // index
                               {0.20, 0.30, 0.15},   // middle
                               {0.25, 0.35, 0.18},   // ring
                               {0.30, 0.40, 0.20}};  // pinky
    for (int f = 0; f < kFingers; ++f)
      for (int k = 0; k < 3; ++k) {
        const int joint = kFingerJoints[f][k];
        const int child = k < 2 ? kFingerJoints[f][k + 1] : -1;
        const Vec3 end = child >= 0 ? joints[child] : b.mesh.positions[b.tips[f]];
        const Vec3 d = normalized(end - joints[joint]);
        const Vec3 axis = normalized(cross(d, palm_normal)) * curl[f][k];
        hands_mean[(joint - 1) * 3 + 0] = axis[0];
        hands_mean[(joint - 1) * 3 + 1] = axis[1];
        hands_mean[(joint - 1) * 3 + 2] = axis[2];
      }
  }
  return hands_mean;
}

Rig build_right_hand() {
  Builder b;
  b.design = make_design();
  build_mesh(b);
  drop_unused_vertices(b);
  orient_outwards(b.mesh);
  const std::vector<double> regressor = joint_regressor(b);
  const std::array<Vec3, kRigJoints> joints = regressed_joints(b.mesh, regressor);
  const std::vector<double> weights = skinning_weights(b);
  const std::vector<double> shapedirs = shape_modes(b, joints);
  const std::vector<double> hands_mean = relaxed_pose(b, joints);

  // Pack the rig (float64).
  const Mesh& mesh = b.mesh;
  const int64_t V = static_cast<int64_t>(mesh.positions.size());
  Rig rig;
  rig.name = "builtin";
  rig.handedness = Handedness::right;
  std::vector<double> positions;
  for (const Vec3& p : mesh.positions) positions.insert(positions.end(), {p[0], p[1], p[2]});
  std::vector<int64_t> faces;
  for (const auto& f : mesh.faces) faces.insert(faces.end(), {f[0], f[1], f[2]});
  const auto f64 = torch::kFloat64;
  rig.v_template = torch::tensor(positions, f64).reshape({V, 3});
  rig.faces = torch::tensor(faces, torch::kInt64).reshape({-1, 3});
  rig.weights = torch::tensor(weights, f64).reshape({V, kRigJoints});
  rig.j_regressor = torch::tensor(regressor, f64).reshape({kRigJoints, V});
  rig.parents.assign(kManoParents.begin(), kManoParents.end());
  // Pose blend shapes are zero: the built-in hand is pure LBS (documented in RIG_FORMAT.md).
  rig.posedirs = torch::zeros({V, 3, kPoseFeatureDim}, f64);
  rig.shapedirs = torch::tensor(shapedirs, f64).reshape({V, 3, kShapeDim});
  rig.hands_mean = torch::tensor(hands_mean, f64);
  for (int f = 0; f < kFingers; ++f) rig.tip_vertices[f] = b.tips[f];
  rig.vertex_labels =
      torch::tensor(std::vector<int64_t>(mesh.labels.begin(), mesh.labels.end()), torch::kInt64);
  return rig;
}

}  // namespace

Rig make_procedural_hand(Handedness handedness) {
  Rig right = build_right_hand();
  if (handedness == Handedness::right) return right;
  Rig left = mirror_rig(right);
  left.name = "builtin";
  return left;
}

}  // namespace handscs
