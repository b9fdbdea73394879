// Test fixtures for the hand module: a small random MANO-layout rig (non-zero pose and shape blend
// shapes) and a plain-loop float64 reference LBS written independently of the tensor version.
#pragma once

#include <ATen/ATen.h>

#include <array>
#include <cmath>
#include <random>
#include <vector>

#include "hand/joint_order.h"
#include "hand/rig.h"

namespace handscs::test {

// Random rig with V vertices: weights rows on the simplex (a few zeros), a regressor of convex
// rows, small random blend shapes. Deterministic for a seed.
inline Rig make_toy_rig(int64_t num_vertices, uint64_t seed) {
  torch::manual_seed(seed);
  const auto f64 = torch::kFloat64;
  Rig rig;
  rig.name = "toy";
  rig.v_template = torch::randn({num_vertices, 3}, f64) * 0.05;
  std::vector<int64_t> faces;
  for (int64_t i = 0; i + 2 < num_vertices; ++i) faces.insert(faces.end(), {i, i + 1, i + 2});
  rig.faces = torch::tensor(faces, torch::kInt64).reshape({-1, 3});
  torch::Tensor w = torch::rand({num_vertices, kRigJoints}, f64);
  w = w * (w > 0.6).to(f64);  // sparse rows, like real skinning weights
  w.select(1, 0).add_(1e-3);  // no empty row
  rig.weights = w / w.sum(1, true);
  torch::Tensor r = torch::rand({kRigJoints, num_vertices}, f64);
  rig.j_regressor = r / r.sum(1, true);
  rig.parents.assign(kManoParents.begin(), kManoParents.end());
  rig.posedirs = torch::randn({num_vertices, 3, kPoseFeatureDim}, f64) * 1e-3;
  rig.shapedirs = torch::randn({num_vertices, 3, kShapeDim}, f64) * 1e-2;
  rig.hands_mean = torch::randn({kPoseDim - 3}, f64) * 0.2;
  rig.tip_vertices = {0, 1, 2, 3, 4};
  return rig;
}

using Mat3 = std::array<std::array<double, 3>, 3>;

// Rodrigues' formula in plain doubles (reference; not for tiny angles).
inline Mat3 reference_rotation(const double* a) {
  const double theta = std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
  Mat3 r{};
  for (int i = 0; i < 3; ++i) r[i][i] = 1.0;
  if (theta == 0) return r;
  const double k[3] = {a[0] / theta, a[1] / theta, a[2] / theta};
  const double K[3][3] = {{0, -k[2], k[1]}, {k[2], 0, -k[0]}, {-k[1], k[0], 0}};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      double kk = 0;
      for (int m = 0; m < 3; ++m) kk += K[i][m] * K[m][j];
      r[i][j] += std::sin(theta) * K[i][j] + (1 - std::cos(theta)) * kk;
    }
  return r;
}

struct ReferenceLbs {
  std::vector<double> vertices;    // [V * 3]
  std::vector<double> joints;      // [21 * 3]
  std::vector<double> transforms;  // [16 * 12] rows of the 3x4 A_k
};

// MANO LBS for one pose in plain loops (pose: 48 values, flat_hand_mean semantics given).
inline ReferenceLbs reference_lbs(const Rig& rig, const std::vector<double>& pose_in,
                                  const std::vector<double>& beta,
                                  const std::array<double, 3>& trans, bool flat_hand_mean) {
  const int64_t V = rig.num_vertices();
  const auto T = rig.v_template.contiguous();
  const auto S = rig.shapedirs.contiguous();
  const auto P = rig.posedirs.contiguous();
  const auto W = rig.weights.contiguous();
  const auto Jr = rig.j_regressor.contiguous();
  const double* t = T.data_ptr<double>();
  const double* s = S.data_ptr<double>();
  const double* p = P.data_ptr<double>();
  const double* w = W.data_ptr<double>();
  const double* jr = Jr.data_ptr<double>();
  std::vector<double> pose = pose_in;
  if (!flat_hand_mean)
    for (int i = 0; i < 45; ++i) pose[3 + i] += rig.hands_mean[i].item<double>();

  std::vector<double> shaped(V * 3);
  for (int64_t v = 0; v < V; ++v)
    for (int c = 0; c < 3; ++c) {
      double x = t[v * 3 + c];
      for (int b = 0; b < kShapeDim; ++b) x += s[(v * 3 + c) * kShapeDim + b] * beta[b];
      shaped[v * 3 + c] = x;
    }
  double J[16][3] = {};
  for (int k = 0; k < 16; ++k)
    for (int64_t v = 0; v < V; ++v)
      for (int c = 0; c < 3; ++c) J[k][c] += jr[k * V + v] * shaped[v * 3 + c];
  std::vector<Mat3> R(16);
  for (int k = 0; k < 16; ++k) R[k] = reference_rotation(&pose[3 * k]);
  double feature[135];
  for (int k = 1; k < 16; ++k)
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        feature[(k - 1) * 9 + i * 3 + j] = R[k][i][j] - (i == j ? 1.0 : 0.0);
  std::vector<double> posed(V * 3);
  for (int64_t v = 0; v < V; ++v)
    for (int c = 0; c < 3; ++c) {
      double x = shaped[v * 3 + c];
      for (int f = 0; f < 135; ++f) x += p[(v * 3 + c) * 135 + f] * feature[f];
      posed[v * 3 + c] = x;
    }
  // G_k as 3x4 (rotation | translation).
  double G[16][3][4];
  for (int k = 0; k < 16; ++k) {
    const int64_t parent = rig.parents[k];
    double local[3][4];
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) local[i][j] = R[k][i][j];
      local[i][3] = J[k][i] - (parent >= 0 ? J[parent][i] : 0.0);
    }
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 4; ++j) {
        if (parent < 0) {
          G[k][i][j] = local[i][j];
          continue;
        }
        double x = j == 3 ? G[parent][i][3] : 0.0;
        for (int m = 0; m < 3; ++m) x += G[parent][i][m] * local[m][j];
        G[k][i][j] = x;
      }
  }
  ReferenceLbs out;
  out.transforms.resize(16 * 12);
  for (int k = 0; k < 16; ++k)
    for (int i = 0; i < 3; ++i) {
      double shift = 0;
      for (int m = 0; m < 3; ++m) shift += G[k][i][m] * J[k][m];
      for (int j = 0; j < 3; ++j) out.transforms[k * 12 + i * 4 + j] = G[k][i][j];
      out.transforms[k * 12 + i * 4 + 3] = G[k][i][3] - shift + trans[i];
    }
  out.vertices.resize(V * 3);
  for (int64_t v = 0; v < V; ++v)
    for (int i = 0; i < 3; ++i) {
      double x = 0;
      for (int k = 0; k < 16; ++k) {
        const double* a = &out.transforms[k * 12 + i * 4];
        x += w[v * 16 + k] *
             (a[0] * posed[v * 3] + a[1] * posed[v * 3 + 1] + a[2] * posed[v * 3 + 2] + a[3]);
      }
      out.vertices[v * 3 + i] = x;
    }
  out.joints.resize(21 * 3);
  for (int k = 0; k < 16; ++k)
    for (int i = 0; i < 3; ++i) out.joints[k * 3 + i] = G[k][i][3] + trans[i];
  for (int f = 0; f < 5; ++f)
    for (int i = 0; i < 3; ++i)
      out.joints[(16 + f) * 3 + i] = out.vertices[rig.tip_vertices[f] * 3 + i];
  return out;
}

}  // namespace handscs::test
