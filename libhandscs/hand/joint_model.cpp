#include "hand/joint_model.h"

#include "core/error.h"
#include "hand/joint_order.h"
#include "hand/so3.h"

namespace handscs {

namespace {

torch::Tensor as_float64(const torch::Tensor& t) { return t.to(torch::kFloat64).contiguous(); }

// MANO21 index of joint k's child: the next joint of its finger, or the finger's tip.
int child_of(int k) {
  for (int f = 0; f < kFingers; ++f)
    for (int level = 0; level < 3; ++level)
      if (kFingerJoints[f][level] == k)
        return level < 2 ? kFingerJoints[f][level + 1] : kTipJoint0 + f;
  return -1;  // the wrist has five children
}

}  // namespace

JointModel make_joint_model(const Rig& rig) {
  require(rig.v_template.defined() && rig.v_template.dim() == 2 && rig.v_template.size(1) == 3,
          "joint model: the rig has no template");
  JointModel m;
  m.handedness = rig.handedness;
  for (int k = 0; k < kRigJoints; ++k) m.parents[k] = rig.parents.at(k);
  const int64_t nv = rig.num_vertices();
  const auto tmpl = as_float64(rig.v_template);
  const auto shapedirs = as_float64(rig.shapedirs).reshape({nv, 3 * kShapeDim});
  const auto regressor = as_float64(rig.j_regressor);
  const auto rest = torch::matmul(regressor, tmpl);                         // [16, 3]
  const auto joint_dirs = torch::matmul(regressor, shapedirs).contiguous();  // [16, 30]
  std::copy_n(rest.data_ptr<double>(), m.rest_joints.size(), m.rest_joints.begin());
  std::copy_n(joint_dirs.data_ptr<double>(), m.joint_shapedirs.size(), m.joint_shapedirs.begin());
  const auto posedirs = as_float64(rig.posedirs);
  const auto weights = as_float64(rig.weights);
  for (int t = 0; t < 5; ++t) {
    const int64_t v = rig.tip_vertices[t];
    require(v >= 0 && v < nv, "joint model: tip vertex out of range");
    for (int c = 0; c < 3; ++c) {
      m.tip_template[3 * t + c] = tmpl[v][c].item<double>();
      for (int s = 0; s < kShapeDim; ++s)
        m.tip_shapedirs[(3 * t + c) * kShapeDim + s] = shapedirs[v][c * kShapeDim + s].item<double>();
    }
    const auto tip_pose = posedirs[v].contiguous();  // [3, 135]
    std::copy_n(tip_pose.data_ptr<double>(), 3 * kPoseFeatureDim,
                m.tip_posedirs.begin() + 3 * kPoseFeatureDim * t);
    const auto tip_w = weights[v].contiguous();
    std::copy_n(tip_w.data_ptr<double>(), kRigJoints, m.tip_weights.begin() + kRigJoints * t);
  }
  if (rig.hands_mean.defined() && rig.hands_mean.numel() == kPoseDim - 3) {
    const auto mean = as_float64(rig.hands_mean);
    std::copy_n(mean.data_ptr<double>(), m.hands_mean.size(), m.hands_mean.begin());
  }
  for (int k = 1; k < kRigJoints; ++k) {
    const int child = child_of(k);
    Vec3 d{};
    for (int c = 0; c < 3; ++c) {
      const double child_rest =
          child < kRigJoints ? m.rest_joints[3 * child + c] : m.tip_template[3 * (child - kTipJoint0) + c];
      d[c] = child_rest - m.rest_joints[3 * k + c];
    }
    const Vec3 axis = normalized(d);
    for (int c = 0; c < 3; ++c) m.child_axis[3 * k + c] = axis[c];
  }
  return m;
}

void joint_positions(const JointModel& m, const JointParams& p, double* joints, double* jacobian) {
  // Rotations, their right Jacobians, and the pose feature (R_k - I) of joints 1..15.
  std::array<Mat3, kRigJoints> R, Jr;
  for (int k = 0; k < kRigJoints; ++k) {
    R[k] = rodrigues_one(&p.pose[3 * k]);
    if (jacobian) Jr[k] = right_jacobian(&p.pose[3 * k]);
  }
  // Rest joints of the shaped hand.
  std::array<Vec3, kRigJoints> J;
  for (int k = 0; k < kRigJoints; ++k)
    for (int c = 0; c < 3; ++c) {
      double v = m.rest_joints[3 * k + c];
      for (int s = 0; s < kShapeDim; ++s) v += m.joint_shapedirs[(3 * k + c) * kShapeDim + s] * p.shape[s];
      J[k][c] = v;
    }
  // The chain: global rotations Rg and posed joints o (translation included).
  std::array<Mat3, kRigJoints> Rg;
  std::array<Vec3, kRigJoints> o;
  for (int k = 0; k < kRigJoints; ++k) {
    const int64_t parent = m.parents[k];
    if (parent < 0) {
      Rg[k] = R[k];
      for (int c = 0; c < 3; ++c) o[k][c] = J[k][c] + p.trans[c];
    } else {
      Rg[k] = mat_mul(Rg[parent], R[k]);
      const Vec3 offset = mat_vec(Rg[parent], J[k] - J[parent]);
      o[k] = o[parent] + offset;
    }
  }
  for (int k = 0; k < kRigJoints; ++k)
    for (int c = 0; c < 3; ++c) joints[3 * k + c] = o[k][c];

  // Tips: shaped and pose-blended rest vertex u, skinned by the tip's weights.
  std::array<double, kPoseFeatureDim> feature;
  for (int k = 1; k < kRigJoints; ++k)
    for (int e = 0; e < 9; ++e) feature[9 * (k - 1) + e] = R[k][e] - (e % 4 == 0 ? 1.0 : 0.0);
  std::array<Vec3, 5> u;
  std::array<std::array<Vec3, kRigJoints>, 5> y;  // Rg_k (u - J_k) + o_k per tip and joint
  for (int t = 0; t < 5; ++t) {
    for (int c = 0; c < 3; ++c) {
      const int row = 3 * t + c;
      double v = m.tip_template[row];
      for (int s = 0; s < kShapeDim; ++s) v += m.tip_shapedirs[row * kShapeDim + s] * p.shape[s];
      const double* pd = &m.tip_posedirs[row * kPoseFeatureDim];
      for (int e = 0; e < kPoseFeatureDim; ++e) v += pd[e] * feature[e];
      u[t][c] = v;
    }
    Vec3 x{0, 0, 0};
    for (int k = 0; k < kRigJoints; ++k) {
      y[t][k] = mat_vec(Rg[k], u[t] - J[k]) + o[k];
      x = x + y[t][k] * m.tip_weights[kRigJoints * t + k];
    }
    for (int c = 0; c < 3; ++c) joints[3 * (kRigJoints + t) + c] = x[c];
  }
  if (!jacobian) return;

  std::fill(jacobian, jacobian + 63 * kJointParams, 0.0);
  auto at = [&](int joint, int c, int column) -> double& {
    return jacobian[(3 * joint + c) * kJointParams + column];
  };
  // ancestor[m][k]: joint m is k or one of k's ancestors.
  std::array<std::array<bool, kRigJoints>, kRigJoints> ancestor{};
  for (int k = 0; k < kRigJoints; ++k)
    for (int a = k; a >= 0; a = static_cast<int>(m.parents[a])) ancestor[a][k] = true;
  // A_m = Rg_m J_r(theta_m): a change d theta_m turns the subtree of m by Rg_m J_r d theta_m about
  // o_m, so a point q of the subtree moves by (A_m d theta) x (q - o_m).
  std::array<Mat3, kRigJoints> A;
  for (int k = 0; k < kRigJoints; ++k) A[k] = mat_mul(Rg[k], Jr[k]);
  for (int j = 0; j < kRigJoints; ++j)
    for (int mm = 0; mm < kRigJoints; ++mm) {
      if (mm == j || !ancestor[mm][j]) continue;
      const Vec3 d = o[j] - o[mm];
      for (int i = 0; i < 3; ++i) {
        const Vec3 col = cross(Vec3{A[mm][i], A[mm][3 + i], A[mm][6 + i]}, d);
        for (int c = 0; c < 3; ++c) at(j, c, 3 * mm + i) = col[c];
      }
    }
  for (int t = 0; t < 5; ++t) {
    const int row_joint = kRigJoints + t;
    const double* w = &m.tip_weights[kRigJoints * t];
    // M = sum_k w_k Rg_k: how a change of u moves the tip.
    Mat3 M{};
    for (int k = 0; k < kRigJoints; ++k)
      for (int e = 0; e < 9; ++e) M[e] += w[k] * Rg[k][e];
    for (int mm = 0; mm < kRigJoints; ++mm) {
      for (int i = 0; i < 3; ++i) {
        const Vec3 axis{A[mm][i], A[mm][3 + i], A[mm][6 + i]};
        Vec3 col{0, 0, 0};
        for (int k = 0; k < kRigJoints; ++k)
          if (w[k] != 0.0 && ancestor[mm][k]) col = col + cross(axis, y[t][k] - o[mm]) * w[k];
        // Pose blend shapes: d(R_m - I)/d theta_m,i = R_m [J_r e_i]_x.
        if (mm >= 1) {
          const Vec3 g{Jr[mm][i], Jr[mm][3 + i], Jr[mm][6 + i]};
          const Mat3 G = {0, -g[2], g[1], g[2], 0, -g[0], -g[1], g[0], 0};
          const Mat3 dR = mat_mul(R[mm], G);
          Vec3 du{0, 0, 0};
          for (int c = 0; c < 3; ++c) {
            const double* pd = &m.tip_posedirs[(3 * t + c) * kPoseFeatureDim + 9 * (mm - 1)];
            for (int e = 0; e < 9; ++e) du[c] += pd[e] * dR[e];
          }
          col = col + mat_vec(M, du);
        }
        for (int c = 0; c < 3; ++c) at(row_joint, c, 3 * mm + i) = col[c];
      }
    }
  }
  // Translation moves every joint (tip weights sum to 1).
  for (int j = 0; j < 21; ++j)
    for (int c = 0; c < 3; ++c) at(j, c, kTransColumn + c) = 1.0;
  // Shape: do_k/dbeta = do_parent/dbeta + Rg_parent (S_k - S_parent), S = J_reg shapedirs.
  std::array<std::array<Vec3, kShapeDim>, kRigJoints> dO;
  for (int k = 0; k < kRigJoints; ++k) {
    const int64_t parent = m.parents[k];
    for (int s = 0; s < kShapeDim; ++s) {
      Vec3 sk;
      for (int c = 0; c < 3; ++c) sk[c] = m.joint_shapedirs[(3 * k + c) * kShapeDim + s];
      if (parent < 0) {
        dO[k][s] = sk;
      } else {
        Vec3 sp;
        for (int c = 0; c < 3; ++c) sp[c] = m.joint_shapedirs[(3 * parent + c) * kShapeDim + s];
        dO[k][s] = dO[parent][s] + mat_vec(Rg[parent], sk - sp);
      }
      for (int c = 0; c < 3; ++c) at(k, c, kShapeColumn + s) = dO[k][s][c];
    }
  }
  for (int t = 0; t < 5; ++t) {
    const double* w = &m.tip_weights[kRigJoints * t];
    for (int s = 0; s < kShapeDim; ++s) {
      Vec3 st;
      for (int c = 0; c < 3; ++c) st[c] = m.tip_shapedirs[(3 * t + c) * kShapeDim + s];
      Vec3 col{0, 0, 0};
      for (int k = 0; k < kRigJoints; ++k) {
        if (w[k] == 0.0) continue;
        Vec3 sk;
        for (int c = 0; c < 3; ++c) sk[c] = m.joint_shapedirs[(3 * k + c) * kShapeDim + s];
        col = col + (mat_vec(Rg[k], st - sk) + dO[k][s]) * w[k];
      }
      for (int c = 0; c < 3; ++c) at(kRigJoints + t, c, kShapeColumn + s) = col[c];
    }
  }
}

}  // namespace handscs
