#include "fit/triangulation.h"

#include <cmath>
#include <limits>

#include "core/symmetric_eigen.h"

namespace handscs {

namespace {

// Gauss-Newton steps on the reprojection error after the DLT: it converges in 2-3 from the DLT's
// start; 10 leaves margin for wide baselines.
constexpr int kRefineSteps = 10;

// Row i of the 3x4 projection P = K [R | t].
std::array<double, 12> projection(const Camera& c) {
  std::array<double, 12> P{};
  for (int r = 0; r < 3; ++r)
    for (int col = 0; col < 4; ++col) {
      double v = 0;
      for (int k = 0; k < 3; ++k) v += c.K[3 * r + k] * (col < 3 ? c.R[3 * k + col] : c.t[k]);
      P[4 * r + col] = v;
    }
  return P;
}

}  // namespace

double reprojection_error(const Camera& camera, const Vec3& point, const std::array<double, 2>& pixel) {
  const auto c = camera.to_camera(point);
  if (!(c[2] > 0)) return std::numeric_limits<double>::infinity();
  const auto uv = camera.project_camera(c);
  return std::hypot(uv[0] - pixel[0], uv[1] - pixel[1]);
}

bool triangulate(const std::vector<Camera>& cameras, const std::vector<Observation>& observations,
                 Vec3& point) {
  if (observations.size() < 2) return false;
  // DLT: each view gives u P3 - P1 = 0 and v P3 - P2 = 0 in homogeneous X; the solution is the
  // eigenvector of the smallest eigenvalue of A^T A. Rows are scaled by 1/(focal length) so views
  // weigh alike whatever their resolution.
  double ata[16] = {};
  for (const Observation& o : observations) {
    const Camera& c = cameras.at(o.view);
    const auto P = projection(c);
    const double scale = 1.0 / c.fx();
    for (int a = 0; a < 2; ++a) {
      double row[4];
      for (int k = 0; k < 4; ++k) row[k] = scale * (o.pixel[a] * P[8 + k] - P[4 * a + k]);
      for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j) ata[4 * i + j] += row[i] * row[j];
    }
  }
  std::vector<double> values, vectors;
  symmetric_eigen(ata, 4, values, vectors);
  const double w = vectors[3];
  if (std::fabs(w) < 1e-12) return false;  // a point at infinity: parallel rays
  Vec3 X = {vectors[0] / w, vectors[1] / w, vectors[2] / w};
  // Gauss-Newton on the pixel residuals (3 x 3 normal equations).
  for (int step = 0; step < kRefineSteps; ++step) {
    double JtJ[9] = {}, Jtr[3] = {};
    for (const Observation& o : observations) {
      const Camera& c = cameras.at(o.view);
      const auto pc = c.to_camera(X);
      if (!(pc[2] > 0)) return false;
      const auto uv = c.project_camera(pc);
      const double r[2] = {uv[0] - o.pixel[0], uv[1] - o.pixel[1]};
      // d(u, v)/d(camera point), then times R.
      const double iz = 1.0 / pc[2];
      const double du[3] = {c.fx() * iz, 0, -c.fx() * pc[0] * iz * iz};
      const double dv[3] = {0, c.fy() * iz, -c.fy() * pc[1] * iz * iz};
      double J[2][3];
      for (int k = 0; k < 3; ++k) {
        J[0][k] = du[0] * c.R[k] + du[1] * c.R[3 + k] + du[2] * c.R[6 + k];
        J[1][k] = dv[0] * c.R[k] + dv[1] * c.R[3 + k] + dv[2] * c.R[6 + k];
      }
      for (int a = 0; a < 2; ++a)
        for (int i = 0; i < 3; ++i) {
          Jtr[i] += J[a][i] * r[a];
          for (int j = 0; j < 3; ++j) JtJ[3 * i + j] += J[a][i] * J[a][j];
        }
    }
    // Solve the 3x3 system by Cramer's rule (it is well conditioned for two or more real views).
    const double det = JtJ[0] * (JtJ[4] * JtJ[8] - JtJ[5] * JtJ[7]) -
                       JtJ[1] * (JtJ[3] * JtJ[8] - JtJ[5] * JtJ[6]) +
                       JtJ[2] * (JtJ[3] * JtJ[7] - JtJ[4] * JtJ[6]);
    if (!(std::fabs(det) > 0)) break;
    Vec3 dx;
    for (int col = 0; col < 3; ++col) {
      double M[9];
      for (int e = 0; e < 9; ++e) M[e] = JtJ[e];
      for (int r = 0; r < 3; ++r) M[3 * r + col] = -Jtr[r];
      dx[col] = (M[0] * (M[4] * M[8] - M[5] * M[7]) - M[1] * (M[3] * M[8] - M[5] * M[6]) +
                 M[2] * (M[3] * M[7] - M[4] * M[6])) / det;
    }
    X = X + dx;
    if (norm(dx) < 1e-12) break;
  }
  for (const Observation& o : observations)
    if (!(cameras.at(o.view).to_camera(X)[2] > 0)) return false;
  point = X;
  return true;
}

RobustPoint triangulate_robust(const std::vector<Camera>& cameras,
                               const std::vector<Observation>& observations, double inlier_px) {
  RobustPoint best;
  const int n = static_cast<int>(observations.size());
  double best_error = std::numeric_limits<double>::infinity();
  auto inliers_of = [&](const Vec3& X, double& error) {
    std::vector<int> in;
    error = 0;
    for (int i = 0; i < n; ++i) {
      const double e = reprojection_error(cameras.at(observations[i].view), X, observations[i].pixel);
      if (e <= inlier_px) {
        in.push_back(i);
        error += e;
      }
    }
    return in;
  };
  for (int a = 0; a < n; ++a)
    for (int b = a + 1; b < n; ++b) {
      if (observations[a].view == observations[b].view) continue;
      Vec3 X;
      if (!triangulate(cameras, {observations[a], observations[b]}, X)) continue;
      double error;
      const auto in = inliers_of(X, error);
      if (in.size() > best.inliers.size() || (in.size() == best.inliers.size() && error < best_error)) {
        best.inliers = in;
        best.point = X;
        best_error = error;
      }
    }
  if (best.inliers.size() < 2) return RobustPoint{};
  std::vector<Observation> chosen;
  for (int i : best.inliers) chosen.push_back(observations[i]);
  Vec3 refined;
  if (triangulate(cameras, chosen, refined)) {
    double error;
    auto in = inliers_of(refined, error);
    if (in.size() >= best.inliers.size()) {
      std::vector<Observation> again;
      for (int i : in) again.push_back(observations[i]);
      if (triangulate(cameras, again, refined)) {
        best.point = refined;
        best.inliers = in;
      }
    } else {
      best.point = refined;
    }
  }
  best.ok = true;
  best.dropped.clear();
  for (int i = 0, k = 0; i < n; ++i) {
    if (k < static_cast<int>(best.inliers.size()) && best.inliers[k] == i) ++k;
    else best.dropped.push_back(i);
  }
  return best;
}

}  // namespace handscs
