#include "hand/keypoint_fit.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

#include <ATen/Parallel.h>

#include "core/progress.h"
#include "core/symmetric_eigen.h"
#include "hand/joint_order.h"
#include "hand/so3.h"

namespace handscs {

namespace {

// Palm joints in MANO21: wrist, then the index, middle, pinky and ring bases (rigid in the palm).
constexpr std::array<int, 5> kPalmJoints = {0, 1, 4, 7, 10};

// Joint limits of the four fingers per level (base, middle, distal joint), in radians, beyond which
// the limit prior acts: hand anatomy's ranges rounded up, so that no real pose is resisted and a
// mirrored hand (a left hand's keypoints on a right rig) is. Backwards: knuckles hyperextend to
// ~40 degrees, middle joints hardly (~10), distal ones ~20. Sideways: knuckles spread ~30
// degrees each way; the other joints barely move sideways, but a fit holds every twist at zero, so
// a parent's real twist shows as sideways bending of its flexed child (a 1.3 rad bend under 0.3
// rad of twist: 0.38 rad), hence ~30 degrees allowed. Twist about the bone: ~20 degrees.
constexpr std::array<double, 3> kBackwardLimit = {0.70, 0.20, 0.35};
constexpr std::array<double, 3> kSidewaysLimit = {0.55, 0.50, 0.50};
constexpr double kTwistLimit = 0.35;

// The canonical frame's back-of-hand direction (MANO: +y, both hands).
constexpr Vec3 kBackOfHand = {0, 1, 0};

// Frames fitted between two updates of the progress line: ~0.2 s of work on 2 threads, and
// enough per block for both threads.
constexpr int64_t kProgressBlock = 256;

// Levenberg-Marquardt damping: start, and the factors after a failed and a good step.
constexpr double kInitialDamping = 1e-3;
constexpr double kDampingUp = 4.0, kDampingDown = 3.0;
// Stop when a step lowers the cost by less than this fraction. On noisy keypoints the steps beyond
// it change the fitted joints by under 0.001 mm and cost as much time again (docs/FIT.md).
constexpr double kRelativeCostTolerance = 1e-6;

using Jac = std::array<double, 63 * kJointParams>;

Vec3 vec_at(const double* a, int i) { return {a[3 * i], a[3 * i + 1], a[3 * i + 2]}; }

// The axes of finger joint k in the canonical frame: its bone; flexion, perpendicular to the bone
// and the back of the hand, so that a positive rotation curls the finger towards the palm; and
// sideways, perpendicular to both.
struct JointAxes {
  Vec3 bone, flexion, sideways;
};
JointAxes joint_axes(const JointModel& m, int k) {
  const Vec3 bone = vec_at(m.child_axis.data(), k);
  const Vec3 flexion = normalized(cross(kBackOfHand, bone));
  return {bone, flexion, cross(bone, flexion)};
}

// How far a finger joint's rotation lies beyond its limits (rad, per limit; <= 0 inside): its
// axis-angle's components on the joint's axes, a first-order split that holds within the limits.
std::array<double, 4> limit_excess(const JointModel& m, const double* theta, int k, int level,
                                   std::array<Vec3, 4>* directions) {
  const JointAxes a = joint_axes(m, k);
  const Vec3 w{theta[0], theta[1], theta[2]};
  const double flex = dot(w, a.flexion), side = dot(w, a.sideways), twist = dot(w, a.bone);
  if (directions)
    *directions = {a.flexion * -1.0, side >= 0 ? a.sideways : a.sideways * -1.0,
                   twist >= 0 ? a.bone : a.bone * -1.0, Vec3{0, 0, 0}};
  return {-flex - kBackwardLimit[level], std::fabs(side) - kSidewaysLimit[level],
          std::fabs(twist) - kTwistLimit, 0.0};
}

// Huber's loss of a distance d with threshold c, and the IRLS weight that gives its gradient.
double huber(double d, double c) { return d <= c ? 0.5 * d * d : c * (d - 0.5 * c); }
double huber_weight(double d, double c) { return d <= c ? 1.0 : c / d; }

// The shape's prior residuals: shape_prior * beta_s for every mode, and limit_weight * the excess
// beyond shape_limit; adds 1/2 r^2 to cost and, when given, r dr/dbeta to gradient and
// (dr/dbeta)^2 to the diagonal of normal (stride: its row length; both offset to the shape block).
double add_shape_prior(const std::array<double, kShapeDim>& beta, const KeypointFitConfig& config, double* normal,
                       int stride, double* gradient) {
  double cost = 0.0;
  for (int s = 0; s < kShapeDim; ++s) {
    auto term = [&](double r, double slope) {
      cost += 0.5 * r * r;
      if (normal) {
        gradient[s] += slope * r;
        normal[s * stride + s] += slope * slope;
      }
    };
    term(config.shape_prior * beta[s], config.shape_prior);
    const double excess = std::fabs(beta[s]) - config.shape_limit;
    if (excess > 0) term(config.limit_weight * excess, beta[s] > 0 ? config.limit_weight : -config.limit_weight);
  }
  return cost;
}

// The residuals and their Jacobian at given parameters: the keypoint rows (weighted by the Huber
// IRLS weights) and the priors, with the cost they add up to.
struct Problem {
  const JointModel& model;
  const HandKeypoints& keypoints;
  const KeypointFitConfig& config;
  bool shape_free;
  const std::array<const JointParams*, 2> neighbours;  // smoothing targets (may be null)
  bool shape_prior = true;  // false: a sequence adds the shape prior once, not per frame

  int num_free() const { return shape_free ? kJointParams : kShapeColumn; }

  // Cost (Huber on keypoints + 1/2 |prior residuals|^2). With normal/gradient given, also the
  // Gauss-Newton normal equations (num_free x num_free) and gradient J^T r.
  double evaluate(const JointParams& p, std::vector<double>* normal,
                  std::vector<double>* gradient) const {
    const int n = num_free();
    std::array<double, 63> x;
    Jac* jac = nullptr;
    Jac storage;
    if (normal) jac = &storage;
    joint_positions(model, p, x.data(), jac ? jac->data() : nullptr);
    if (normal) {
      normal->assign(static_cast<size_t>(n) * n, 0.0);
      gradient->assign(n, 0.0);
    }
    const double c = config.huber_mm * 1e-3;
    double cost = 0.0;
    std::array<int, kJointParams> nonzero;
    auto add_row = [&](const double* row, double r, double w) {  // w: IRLS weight of the row
      if (!normal) return;
      // A joint sees only its chain's rotations, the translation and the shape (~25 of 61
      // columns); a prior row one joint: the products run over the non-zero entries alone.
      int count = 0;
      for (int a = 0; a < n; ++a)
        if (row[a] != 0.0) nonzero[count++] = a;
      for (int i = 0; i < count; ++i) {
        const int a = nonzero[i];
        const double wa = w * row[a];
        (*gradient)[a] += wa * r;
        for (int k = 0; k <= i; ++k) (*normal)[a * n + nonzero[k]] += wa * row[nonzero[k]];
      }
    };
    for (int j = 0; j < 21; ++j) {
      if (!keypoints.valid[j]) continue;
      const Vec3 d = vec_at(x.data(), j) - vec_at(keypoints.joints.data(), j);
      const double dist = norm(d);
      cost += huber(dist, c);
      const double w = huber_weight(dist, c);
      for (int k = 0; k < 3; ++k) add_row(jac ? &(*jac)[(3 * j + k) * kJointParams] : nullptr, d[k], w);
    }
    std::array<double, kJointParams> row;
    auto prior = [&](double r) { cost += 0.5 * r * r; };
    auto prior_row = [&](double r) {
      prior(r);
      if (normal) add_row(row.data(), r, 1.0);
    };
    for (int k = 1; k < kRigJoints; ++k) {
      const Vec3 theta = vec_at(p.pose.data(), k);
      for (int i = 0; i < 3; ++i) {
        row.fill(0.0);
        row[3 * k + i] = config.pose_prior;
        prior_row(config.pose_prior * (theta[i] - model.hands_mean[3 * (k - 1) + i]));
      }
      const Vec3 axis = vec_at(model.child_axis.data(), k);
      row.fill(0.0);
      for (int i = 0; i < 3; ++i) row[3 * k + i] = config.twist_prior * axis[i];
      prior_row(config.twist_prior * dot(theta, axis));
    }
    for (int f = kIndex; f < kFingers; ++f)
      for (int level = 0; level < 3; ++level) {
        const int k = kFingerJoints[f][level];
        std::array<Vec3, 4> directions;
        const auto excess = limit_excess(model, &p.pose[3 * k], k, level, &directions);
        for (int l = 0; l < 3; ++l) {
          if (excess[l] <= 0.0) continue;
          row.fill(0.0);
          for (int i = 0; i < 3; ++i) row[3 * k + i] = config.limit_weight * directions[l][i];
          prior_row(config.limit_weight * excess[l]);
        }
      }
    for (const JointParams* other : neighbours) {
      if (!other || config.smoothing <= 0) continue;
      for (int i = 0; i < kPoseDim; ++i) {
        row.fill(0.0);
        row[i] = config.smoothing;
        prior_row(config.smoothing * (p.pose[i] - other->pose[i]));
      }
    }
    if (shape_free && shape_prior)
      cost += add_shape_prior(p.shape, config, normal ? normal->data() + kShapeColumn * n + kShapeColumn : nullptr, n,
                              normal ? gradient->data() + kShapeColumn : nullptr);
    return cost;
  }
};

// Solves (A + damping diag(A)) x = -g by Cholesky (A symmetric, lower triangle filled); false when
// the damped matrix is not positive definite.
bool solve_damped(std::vector<double> A, const std::vector<double>& g, int n, double damping,
                  std::vector<double>& x) {
  for (int i = 0; i < n; ++i) {
    // The absolute floor keeps a parameter no residual sees (a shape mode without a joint effect
    // and no prior) from making the matrix singular.
    A[i * n + i] += damping * A[i * n + i] + 1e-12;
  }
  for (int j = 0; j < n; ++j) {
    double d = A[j * n + j];
    for (int k = 0; k < j; ++k) d -= A[j * n + k] * A[j * n + k];
    if (!(d > 0.0)) return false;
    d = std::sqrt(d);
    A[j * n + j] = d;
    for (int i = j + 1; i < n; ++i) {
      double s = A[i * n + j];
      for (int k = 0; k < j; ++k) s -= A[i * n + k] * A[j * n + k];
      A[i * n + j] = s / d;
    }
  }
  x.assign(n, 0.0);
  for (int i = 0; i < n; ++i) {
    double s = -g[i];
    for (int k = 0; k < i; ++k) s -= A[i * n + k] * x[k];
    x[i] = s / A[i * n + i];
  }
  for (int i = n - 1; i >= 0; --i) {
    double s = x[i];
    for (int k = i + 1; k < n; ++k) s -= A[k * n + i] * x[k];
    x[i] = s / A[i * n + i];
  }
  return true;
}

JointParams step(const JointParams& p, const std::vector<double>& dx) {
  JointParams q = p;
  for (int i = 0; i < kPoseDim; ++i) q.pose[i] += dx[i];
  for (int i = 0; i < 3; ++i) q.trans[i] += dx[kTransColumn + i];
  if (static_cast<int>(dx.size()) > kShapeColumn)
    for (int s = 0; s < kShapeDim; ++s) q.shape[s] += dx[kShapeColumn + s];
  return q;
}

// Levenberg-Marquardt from p; returns the steps taken.
int minimise(const Problem& problem, JointParams& p, int iterations) {
  const int n = problem.num_free();
  std::vector<double> A, g, dx;
  double damping = kInitialDamping;
  int taken = 0;
  for (int it = 0; it < iterations; ++it) {
    const double cost = problem.evaluate(p, &A, &g);
    for (int a = 0; a < n; ++a)
      for (int b = a + 1; b < n; ++b) A[a * n + b] = A[b * n + a];
    bool improved = false;
    // Raise the damping until a step lowers the cost (at most a few tries: 4^8 = 65,536 x).
    for (int attempt = 0; attempt < 8 && !improved; ++attempt) {
      if (solve_damped(A, g, n, damping, dx)) {
        const JointParams q = step(p, dx);
        const double trial = problem.evaluate(q, nullptr, nullptr);
        if (trial < cost) {
          improved = true;
          p = q;
          damping = std::max(damping / kDampingDown, 1e-9);
          ++taken;
          if (cost - trial <= kRelativeCostTolerance * cost) return taken;
          break;
        }
      }
      damping *= kDampingUp;
    }
    if (!improved) break;
  }
  return taken;
}

std::array<Mat3, kRigJoints> global_rotations(const JointModel& m, const JointParams& p) {
  std::array<Mat3, kRigJoints> Rg;
  for (int k = 0; k < kRigJoints; ++k) {
    const Mat3 R = rodrigues_one(&p.pose[3 * k]);
    Rg[k] = m.parents[k] < 0 ? R : mat_mul(Rg[m.parents[k]], R);
  }
  return Rg;
}

// The rotation taking unit direction a to unit direction b about their common perpendicular.
Mat3 rotation_between(const Vec3& a, const Vec3& b) {
  const Vec3 axis = cross(a, b);
  const double s = norm(axis), c = dot(a, b);
  if (s < 1e-12) return {1, 0, 0, 0, 1, 0, 0, 0, 1};  // parallel (antiparallel is never a bone's init)
  const double angle = std::atan2(s, c);
  const Vec3 v = axis * (angle / s);
  return rodrigues_one(v.data());
}

// The rotation that best maps the points a_j - mean_a onto b_j - mean_b (least squares): Horn's
// quaternion, the eigenvector of the largest eigenvalue of his 4x4 matrix.
Mat3 best_rotation(const std::vector<int>& ids, const double* a, const double* b, const Vec3& mean_a,
                   const Vec3& mean_b) {
  std::array<double, 9> S{};  // S[3r + c] = sum (a - mean_a)_r (b - mean_b)_c
  for (int j : ids) {
    const Vec3 p = vec_at(a, j) - mean_a, q = vec_at(b, j) - mean_b;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) S[3 * r + c] += p[r] * q[c];
  }
  const double xx = S[0], xy = S[1], xz = S[2], yx = S[3], yy = S[4], yz = S[5], zx = S[6], zy = S[7],
               zz = S[8];
  const double N[16] = {xx + yy + zz, yz - zy,      zx - xz,       xy - yx,
                        yz - zy,      xx - yy - zz, xy + yx,       zx + xz,
                        zx - xz,      xy + yx,      -xx + yy - zz, yz + zy,
                        xy - yx,      zx + xz,      yz + zy,       -xx - yy + zz};
  std::vector<double> values, vectors;
  symmetric_eigen(N, 4, values, vectors);
  const double w = vectors[12], x = vectors[13], y = vectors[14], z = vectors[15];
  return {w * w + x * x - y * y - z * z, 2 * (x * y - w * z), 2 * (x * z + w * y),
          2 * (x * y + w * z), w * w - x * x + y * y - z * z, 2 * (y * z - w * x),
          2 * (x * z - w * y), 2 * (y * z + w * x), w * w - x * x - y * y + z * z};
}

// A start close to the answer: the palm rotated and moved onto its keypoints (Kabsch), then each
// finger bone turned (without twist) to point at its child's keypoint, base to tip.
JointParams initial_params(const JointModel& m, const HandKeypoints& k,
                           const std::array<double, kShapeDim>& shape) {
  JointParams p;
  p.shape = shape;
  std::array<double, 63> rest;
  joint_positions(m, p, rest.data());
  std::vector<int> palm;
  for (int j : kPalmJoints)
    if (k.valid[j]) palm.push_back(j);
  if (palm.size() >= 3) {
    Vec3 mean_rest{0, 0, 0}, mean_target{0, 0, 0};
    for (int j : palm) {
      mean_rest = mean_rest + vec_at(rest.data(), j) * (1.0 / palm.size());
      mean_target = mean_target + vec_at(k.joints.data(), j) * (1.0 / palm.size());
    }
    const Mat3 R0 = best_rotation(palm, rest.data(), k.joints.data(), mean_rest, mean_target);
    const Vec3 w = rotation_log(R0);
    for (int i = 0; i < 3; ++i) p.pose[i] = w[i];
    // target = R0 (rest - J0) + J0 + trans at the means.
    const Vec3 wrist = vec_at(rest.data(), 0);
    const Vec3 moved = mat_vec(R0, mean_rest - wrist) + wrist;
    for (int i = 0; i < 3; ++i) p.trans[i] = mean_target[i] - moved[i];
  } else if (k.valid[0]) {
    for (int i = 0; i < 3; ++i) p.trans[i] = k.joints[i] - rest[i];
  }
  std::array<double, 63> x;
  for (int f = 0; f < kFingers; ++f)
    for (int level = 0; level < 3; ++level) {
      const int joint = kFingerJoints[f][level];
      const int child = level < 2 ? kFingerJoints[f][level + 1] : kTipJoint0 + f;
      if (!k.valid[child]) continue;
      joint_positions(m, p, x.data());
      const Vec3 here = vec_at(x.data(), joint);
      const Vec3 now = normalized(vec_at(x.data(), child) - here);
      const Vec3 want = normalized(vec_at(k.joints.data(), child) - here);
      if (norm(want) == 0.0) continue;
      const auto Rg = global_rotations(m, p);
      const Mat3& parent = Rg[m.parents[joint]];
      const Mat3 turn = mat_mul(mat_mul(mat_transpose(parent), rotation_between(now, want)), parent);
      const Mat3 R = mat_mul(turn, rodrigues_one(&p.pose[3 * joint]));
      const Vec3 w = rotation_log(R);
      for (int i = 0; i < 3; ++i) p.pose[3 * joint + i] = w[i];
    }
  return p;
}

void finish(const JointModel& m, const HandKeypoints& k, HandFit& fit) {
  joint_positions(m, fit.params, fit.joints.data());
  double sum = 0, worst = 0;
  int count = 0;
  for (int j = 0; j < 21; ++j) {
    if (!k.valid[j]) {
      fit.residual_mm[j] = std::numeric_limits<double>::quiet_NaN();
      continue;
    }
    const double d = 1e3 * norm(vec_at(fit.joints.data(), j) - vec_at(k.joints.data(), j));
    fit.residual_mm[j] = d;
    sum += d;
    worst = std::max(worst, d);
    ++count;
  }
  fit.mean_mm = count ? sum / count : std::numeric_limits<double>::quiet_NaN();
  fit.max_mm = worst;
  fit.limit_excess = 0.0;
  for (int f = kIndex; f < kFingers; ++f)
    for (int level = 0; level < 3; ++level) {
      const int joint = kFingerJoints[f][level];
      for (double e : limit_excess(m, &fit.params.pose[3 * joint], joint, level, nullptr))
        fit.limit_excess = std::max(fit.limit_excess, e);
    }
}

HandFit fit_pose(const JointModel& m, const HandKeypoints& k, const KeypointFitConfig& config,
                 const std::array<double, kShapeDim>& shape, bool shape_free,
                 const JointParams* start, std::array<const JointParams*, 2> neighbours) {
  HandFit fit;
  fit.params = start ? *start : initial_params(m, k, shape);
  if (!start) fit.params.shape = shape;
  const Problem problem{m, k, config, shape_free, neighbours};
  fit.iterations = minimise(problem, fit.params, config.iterations);
  fit.fitted = true;
  finish(m, k, fit);
  return fit;
}

// One Levenberg-Marquardt on every frame's pose and the shared shape together. The normal
// equations have an arrow form (each frame's 51 pose parameters couple only to themselves and to
// the 10 shape coefficients), solved by the Schur complement on the shape: per frame
// A_f dx_f + B_f db = -g_f, and (C - sum B_f^T A_f^-1 B_f) db = -g_b + sum B_f^T A_f^-1 g_f.
void fit_poses_and_shape(const JointModel& m, const std::vector<HandKeypoints>& frames,
                         std::vector<HandFit>& fits, const KeypointFitConfig& config,
                         std::array<double, kShapeDim>& shape) {
  const int64_t count = static_cast<int64_t>(frames.size());
  constexpr int P = kShapeColumn, S = kShapeDim, N = kJointParams;
  struct FrameSystem {
    std::vector<double> normal, gradient;
    double cost = 0;
  };
  std::vector<FrameSystem> systems(frames.size());
  auto shape_prior_cost = [&](const std::array<double, S>& beta) {
    return add_shape_prior(beta, config, nullptr, 0, nullptr);
  };
  // Every fitted frame's cost at its pose and `beta` (with its normal equations when `with_system`),
  // into systems; returns the total with the shape prior, summed in frame order (the same sum for
  // any thread count).
  auto evaluate_all = [&](const std::vector<JointParams>& params, const std::array<double, S>& beta,
                          bool with_system) {
    at::parallel_for(0, count, 1, [&](int64_t begin, int64_t end) {
      for (int64_t f = begin; f < end; ++f) {
        if (!fits[f].fitted) continue;
        JointParams p = params[f];
        p.shape = beta;
        const Problem problem{m, frames[f], config, true, {}, false};
        systems[f].cost = with_system ? problem.evaluate(p, &systems[f].normal, &systems[f].gradient)
                                      : problem.evaluate(p, nullptr, nullptr);
      }
    });
    double c = shape_prior_cost(beta);
    for (int64_t f = 0; f < count; ++f)
      if (fits[f].fitted) c += systems[f].cost;
    return c;
  };
  std::vector<JointParams> params(frames.size());
  for (size_t f = 0; f < frames.size(); ++f) params[f] = fits[f].params;
  double damping = kInitialDamping;
  for (int it = 0; it < config.iterations; ++it) {
    const double cost = evaluate_all(params, shape, true);
    bool improved = false;
    for (int attempt = 0; attempt < 8 && !improved; ++attempt) {
      // Per frame: A_f^-1 B_f and A_f^-1 g_f by Cholesky of the damped pose block.
      std::vector<std::vector<double>> a_inv_b(frames.size()), a_inv_g(frames.size());
      std::vector<uint8_t> ok(frames.size(), 1);
      at::parallel_for(0, count, 1, [&](int64_t begin, int64_t end) {
        for (int64_t f = begin; f < end; ++f) {
          if (!fits[f].fitted) continue;
          const auto& n = systems[f].normal;
          std::vector<double> A(P * P), g(P), x;
          for (int a = 0; a < P; ++a) {
            g[a] = systems[f].gradient[a];
            for (int b = 0; b <= a; ++b) A[a * P + b] = A[b * P + a] = n[a * N + b];
          }
          // A^-1 (-g) and A^-1 (-B e_s): solve_damped returns the solution for -rhs.
          if (!solve_damped(A, g, P, damping, x)) { ok[f] = 0; continue; }
          a_inv_g[f] = x;  // = -A^-1 g
          a_inv_b[f].assign(P * S, 0.0);
          for (int s = 0; s < S; ++s) {
            std::vector<double> col(P);
            for (int a = 0; a < P; ++a) col[a] = n[(P + s) * N + a];  // B[a][s] (lower triangle)
            if (!solve_damped(A, col, P, damping, x)) { ok[f] = 0; break; }
            for (int a = 0; a < P; ++a) a_inv_b[f][a * S + s] = -x[a];  // A^-1 B e_s
          }
        }
      });
      bool all_ok = true;
      for (int64_t f = 0; f < count; ++f) all_ok = all_ok && (ok[f] || !fits[f].fitted);
      if (all_ok) {
        // Reduced system on the shape, summed in frame order.
        std::vector<double> schur(S * S, 0.0), rhs(S, 0.0), prior_gradient(S, 0.0);
        add_shape_prior(shape, config, schur.data(), S, prior_gradient.data());
        for (int s = 0; s < S; ++s) rhs[s] -= prior_gradient[s];
        for (int64_t f = 0; f < count; ++f) {
          if (!fits[f].fitted) continue;
          const auto& n = systems[f].normal;
          for (int a = 0; a < S; ++a) {
            rhs[a] -= systems[f].gradient[P + a];
            for (int b = 0; b < S; ++b) schur[a * S + b] += n[std::max(P + a, P + b) * N + std::min(P + a, P + b)];
            // - B^T A^-1 B and + B^T A^-1 g (a_inv_g holds -A^-1 g).
            for (int k = 0; k < P; ++k) {
              const double bka = n[(P + a) * N + k];
              rhs[a] += bka * a_inv_g[f][k];
              for (int b = 0; b < S; ++b) schur[a * S + b] -= bka * a_inv_b[f][k * S + b];
            }
          }
        }
        // solve_damped solves (M + damping diag(M)) x = -g: pass -rhs as g.
        std::vector<double> neg_rhs(S), db;
        for (int a = 0; a < S; ++a) neg_rhs[a] = -rhs[a];
        if (solve_damped(schur, neg_rhs, S, damping, db)) {
          std::array<double, S> trial_shape = shape;
          for (int s = 0; s < S; ++s) trial_shape[s] += db[s];
          std::vector<JointParams> trial = params;
          for (int64_t f = 0; f < count; ++f) {
            if (!fits[f].fitted) continue;
            std::vector<double> dx(P);
            for (int a = 0; a < P; ++a) {
              double v = a_inv_g[f][a];
              for (int s = 0; s < S; ++s) v -= a_inv_b[f][a * S + s] * db[s];
              dx[a] = v;
            }
            trial[f] = step(params[f], dx);
          }
          // The trial's costs overwrite systems[].cost only: the normal equations stay this step's.
          const double trial_cost = evaluate_all(trial, trial_shape, false);
          if (trial_cost < cost) {
            improved = true;
            params = trial;
            shape = trial_shape;
            damping = std::max(damping / kDampingDown, 1e-9);
            if (cost - trial_cost <= kRelativeCostTolerance * cost) it = config.iterations;
            break;
          }
        }
      }
      damping *= kDampingUp;
    }
    if (!improved) break;
  }
  for (size_t f = 0; f < frames.size(); ++f) {
    fits[f].params = params[f];
    fits[f].params.shape = shape;
  }
}

}  // namespace

int HandKeypoints::num_valid() const {
  int n = 0;
  for (uint8_t v : valid) n += v ? 1 : 0;
  return n;
}

HandFit fit_keypoints(const JointModel& model, const HandKeypoints& keypoints,
                      const KeypointFitConfig& config, const std::array<double, kShapeDim>& shape) {
  require(keypoints.num_valid() >= kMinFitKeypoints,
          "keypoint fit: " + std::to_string(keypoints.num_valid()) + " valid keypoints, at least " +
              std::to_string(kMinFitKeypoints) + " needed");
  if (!config.fit_shape) return fit_pose(model, keypoints, config, shape, false, nullptr, {});
  // Pose first with the given shape (the start is far from the answer), then pose and shape.
  HandFit first = fit_pose(model, keypoints, config, shape, false, nullptr, {});
  HandFit fit = fit_pose(model, keypoints, config, shape, true, &first.params, {});
  fit.iterations += first.iterations;
  return fit;
}

std::vector<HandFit> fit_keypoint_sequence(const JointModel& model,
                                           const std::vector<HandKeypoints>& frames,
                                           const KeypointFitConfig& config, const std::string& progress_label) {
  const int64_t count = static_cast<int64_t>(frames.size());
  std::vector<HandFit> fits(frames.size());
  std::array<double, kShapeDim> shape{};
  // Every frame's pose alone first (the start is far from the answer), then poses and the shared
  // shape together. The frames go in blocks so that the progress line moves between them.
  std::optional<ProgressBar> progress;
  if (!progress_label.empty() && count > kProgressBlock) progress.emplace(progress_label, count, "frames");
  for (int64_t block = 0; block < count; block += kProgressBlock) {
    at::parallel_for(block, std::min(count, block + kProgressBlock), 1, [&](int64_t begin, int64_t end) {
      for (int64_t f = begin; f < end; ++f)
        if (frames[f].num_valid() >= kMinFitKeypoints)
          fits[f] = fit_pose(model, frames[f], config, shape, false, nullptr, {});
    });
    if (progress) progress->update(std::min(count, block + kProgressBlock), "poses");
  }
  if (config.fit_shape) {
    if (progress) progress->update(count, "the shared shape with every pose");
    fit_poses_and_shape(model, frames, fits, config, shape);
  }
  if (progress) progress->finish();
  // Smoothing pulls each pose towards its neighbours' (as just fitted), with the shape held.
  if (config.smoothing <= 0) {
    for (size_t f = 0; f < frames.size(); ++f)
      if (fits[f].fitted) finish(model, frames[f], fits[f]);
    return fits;
  }
  const std::vector<HandFit> previous = fits;
  at::parallel_for(0, count, 1, [&](int64_t begin, int64_t end) {
    for (int64_t f = begin; f < end; ++f) {
      if (!previous[f].fitted) continue;
      std::array<const JointParams*, 2> neighbours{};
      if (f > 0 && previous[f - 1].fitted) neighbours[0] = &previous[f - 1].params;
      if (f + 1 < count && previous[f + 1].fitted) neighbours[1] = &previous[f + 1].params;
      const int steps = previous[f].iterations;
      fits[f] = fit_pose(model, frames[f], config, shape, false, &previous[f].params, neighbours);
      fits[f].iterations += steps;
    }
  });
  return fits;
}

std::array<double, kPoseDim> rig_pose(const JointModel& model, const JointParams& params,
                                      bool flat_hand_mean) {
  std::array<double, kPoseDim> pose = params.pose;
  if (!flat_hand_mean)
    for (int i = 3; i < kPoseDim; ++i) pose[i] -= model.hands_mean[i - 3];
  return pose;
}

std::array<double, kPoseDim> absolute_pose(const JointModel& model,
                                           const std::array<double, kPoseDim>& pose,
                                           bool flat_hand_mean) {
  std::array<double, kPoseDim> out = pose;
  if (!flat_hand_mean)
    for (int i = 3; i < kPoseDim; ++i) out[i] += model.hands_mean[i - 3];
  return out;
}

std::array<double, 15> joint_bend_angles(const double* joints) {
  std::array<double, 15> angles{};
  for (int f = 0; f < kFingers; ++f)
    for (int level = 0; level < 3; ++level) {
      const int joint = kFingerJoints[f][level];
      const int parent = level == 0 ? 0 : kFingerJoints[f][level - 1];
      const int child = level < 2 ? kFingerJoints[f][level + 1] : kTipJoint0 + f;
      const Vec3 in = normalized(vec_at(joints, joint) - vec_at(joints, parent));
      const Vec3 out = normalized(vec_at(joints, child) - vec_at(joints, joint));
      angles[joint - 1] = std::atan2(norm(cross(in, out)), dot(in, out));
    }
  return angles;
}

}  // namespace handscs
