// Triangulation of one point seen by several calibrated cameras: the linear (DLT) estimate, refined
// by Gauss-Newton on the reprojection error, and a robust version that drops views which disagree.
//   minimise sum_i |pi_i(X) - u_i|^2, pi_i(X) = project(K_i (R_i X + t_i))
#pragma once

#include <array>
#include <vector>

#include "core/camera.h"
#include "core/vec3.h"

namespace handscs {

struct Observation {
  int view = 0;                  // index into the camera list
  std::array<double, 2> pixel{};  // (u, v), the project's pixel-centre convention
};

// Reprojection error (px) of X in the observation's camera; infinity behind the camera.
double reprojection_error(const Camera& camera, const Vec3& point, const std::array<double, 2>& pixel);

// Least-squares point from >= 2 observations: DLT, then Gauss-Newton on the pixel errors.
// Returns false when the views do not determine a point in front of them.
bool triangulate(const std::vector<Camera>& cameras, const std::vector<Observation>& observations,
                 Vec3& point);

struct RobustPoint {
  bool ok = false;
  Vec3 point{};
  std::vector<int> inliers;   // indices into the observations given
  std::vector<int> dropped;   // the others
};

// Every pair of observations proposes a point; the one that most observations reproject within
// `inlier_px` of (ties: smallest summed error) is refined on those observations alone, and the
// inlier set is taken again once from the refined point.
RobustPoint triangulate_robust(const std::vector<Camera>& cameras,
                               const std::vector<Observation>& observations, double inlier_px);

}  // namespace handscs
