#include "hand/lbs_one_pose.h"

#include <array>
#include <cmath>
#include <string>

#include <ATen/Parallel.h>

#include "hand/so3.h"


namespace handscs {

namespace {

using Mat4 = std::array<double, 16>;  // row-major

Mat4 multiply(const Mat4& a, const Mat4& b) {
  Mat4 out{};
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j)
      for (int k = 0; k < 4; ++k) out[4 * i + j] += a[4 * i + k] * b[4 * k + j];
  return out;
}

torch::Tensor doubles(const torch::Tensor& t) { return t.to(torch::kFloat64).contiguous(); }

// a . b in four independent running sums: one sum would wait on its own previous addition at every
// term (the pose blend shapes' 135-term products were most of this file's time).
double dot_n(const double* a, const double* b, int n) {
  double s0 = 0.0, s1 = 0.0, s2 = 0.0, s3 = 0.0;
  int i = 0;
  for (; i + 4 <= n; i += 4) {
    s0 += a[i] * b[i];
    s1 += a[i + 1] * b[i + 1];
    s2 += a[i + 2] * b[i + 2];
    s3 += a[i + 3] * b[i + 3];
  }
  for (; i < n; ++i) s0 += a[i] * b[i];
  return (s0 + s1) + (s2 + s3);
}

// Rows of vertices per parallel task: V = 778 gives a task per thread on a few cores.
constexpr int64_t kVertexGrain = 64;

}  // namespace

namespace {

// [n] or [1, n]: one pose's values.
void check_vector(const torch::Tensor& t, int64_t n, const char* what) {
  TORCH_CHECK(t.defined() && t.numel() == n && (t.dim() == 1 || (t.dim() == 2 && t.size(0) == 1)),
              "lbs_one_pose: ", what, " must be [", n, "] or [1, ", n, "], got ",
              t.defined() ? t.sizes() : torch::IntArrayRef{});
  TORCH_CHECK(t.is_cpu(), "lbs_one_pose: ", what, " must be a CPU tensor");
}

// The rig's arrays are read through raw pointers: each must hold what its shape promises.
void check_rig_array(const torch::Tensor& t, int64_t numel, const char* name) {
  TORCH_CHECK(t.defined() && t.numel() == numel && t.is_cpu(), "lbs_one_pose: the rig's ", name,
              " must hold ", numel, " values on the CPU, got ",
              t.defined() ? std::to_string(t.numel()) : std::string("none"));
}

}  // namespace

LbsOutput lbs_one_pose(const Rig& rig, const torch::Tensor& pose_in, const torch::Tensor& shape_in,
                       const torch::Tensor& trans_in, const LbsOptions& options) {
  TORCH_CHECK(rig.v_template.defined() && rig.v_template.dim() == 2 && rig.v_template.size(1) == 3,
              "lbs_one_pose: the rig has no template (load it with load_rig or load_rig_source)");
  check_vector(pose_in, kPoseDim, "pose");
  check_vector(shape_in, kShapeDim, "shape");
  check_vector(trans_in, 3, "trans");
  const int64_t vertices_in_rig = rig.num_vertices();
  check_rig_array(rig.v_template, vertices_in_rig * 3, "v_template");
  check_rig_array(rig.shapedirs, vertices_in_rig * 3 * kShapeDim, "shapedirs");
  check_rig_array(rig.posedirs, vertices_in_rig * 3 * kPoseFeatureDim, "posedirs");
  check_rig_array(rig.weights, vertices_in_rig * kRigJoints, "weights");
  check_rig_array(rig.j_regressor, kRigJoints * vertices_in_rig, "j_regressor");
  if (!options.flat_hand_mean) check_rig_array(rig.hands_mean, kPoseDim - 3, "hands_mean");
  const auto dtype = pose_in.scalar_type();
  TORCH_CHECK(dtype == torch::kFloat32 || dtype == torch::kFloat64,
              "lbs_one_pose: expected a float32 or float64 pose, got ", dtype);
  TORCH_CHECK(rig.parents.size() == kRigJoints, "lbs_one_pose: the rig needs 16 parents, got ",
              rig.parents.size());
  torch::NoGradGuard no_grad;
  const int64_t nv = rig.num_vertices();

  const auto pose = doubles(pose_in.reshape({kPoseDim}));
  const auto beta = doubles(shape_in.reshape({kShapeDim}));
  const auto trans = doubles(trans_in.reshape({3}));
  const auto tmpl = doubles(rig.v_template), shapedirs = doubles(rig.shapedirs);
  const auto posedirs = doubles(rig.posedirs), weights = doubles(rig.weights);
  const auto regressor = doubles(rig.j_regressor);
  const double* pp = pose.data_ptr<double>();
  const double* bp = beta.data_ptr<double>();
  const double* tp = trans.data_ptr<double>();
  const double* tmp = tmpl.data_ptr<double>();
  const double* sdp = shapedirs.data_ptr<double>();
  const double* pdp = posedirs.data_ptr<double>();
  const double* wp = weights.data_ptr<double>();
  const double* rp = regressor.data_ptr<double>();

  // Rotations of the full pose and the 135-D pose feature (R_k - I of the 15 finger joints).
  std::array<double, kPoseDim> full_pose;
  for (int i = 0; i < kPoseDim; ++i) full_pose[i] = pp[i];
  if (!options.flat_hand_mean) {
    const auto mean = doubles(rig.hands_mean);
    for (int i = 3; i < kPoseDim; ++i) full_pose[i] += mean.data_ptr<double>()[i - 3];
  }
  std::array<Mat3, kRigJoints> rotations;
  for (int k = 0; k < kRigJoints; ++k) rotations[k] = rodrigues_one(&full_pose[3 * k]);
  std::array<double, kPoseFeatureDim> feature;
  for (int k = 1; k < kRigJoints; ++k)
    for (int e = 0; e < 9; ++e) feature[9 * (k - 1) + e] = rotations[k][e] - (e % 4 == 0 ? 1.0 : 0.0);

  // Shape and pose blend shapes per vertex.
  auto v_shaped = torch::empty({1, nv, 3}, torch::kFloat64);
  auto v_posed = torch::empty({1, nv, 3}, torch::kFloat64);
  double* vsp = v_shaped.data_ptr<double>();
  double* vpp = v_posed.data_ptr<double>();
  at::parallel_for(0, nv, kVertexGrain, [&](int64_t begin, int64_t end) {
    for (int64_t v = begin; v < end; ++v)
      for (int c = 0; c < 3; ++c) {
        const int64_t row = 3 * v + c;
        double shaped = tmp[row];
        for (int s = 0; s < kShapeDim; ++s) shaped += sdp[row * kShapeDim + s] * bp[s];
        vsp[row] = shaped;
        vpp[row] = shaped + dot_n(pdp + row * kPoseFeatureDim, feature.data(), kPoseFeatureDim);
      }
  });

  // Rest joints J = J_reg v_shaped, then the kinematic chain G_k = G_parent [R_k | J_k - J_parent].
  // Vertex by vertex, so the 48 sums advance side by side (each still in vertex order).
  std::array<std::array<double, 3>, kRigJoints> rest{};
  for (int64_t v = 0; v < nv; ++v)
    for (int k = 0; k < kRigJoints; ++k)
      for (int c = 0; c < 3; ++c) rest[k][c] += rp[k * nv + v] * vsp[3 * v + c];
  std::array<Mat4, kRigJoints> global;
  for (int k = 0; k < kRigJoints; ++k) {
    const int64_t parent = rig.parents[k];
    TORCH_CHECK(parent < k, "lbs_one_pose: joint ", k, " has parent ", parent,
                " (parents must come first)");
    Mat4 local{};
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) local[4 * i + j] = rotations[k][3 * i + j];
      local[4 * i + 3] = parent < 0 ? rest[k][i] : rest[k][i] - rest[parent][i];
    }
    local[15] = 1.0;
    global[k] = parent < 0 ? local : multiply(global[parent], local);
  }
  // A_k: G_k with the rest joint removed, then translated.
  auto joint_transforms = torch::zeros({1, kRigJoints, 4, 4}, torch::kFloat64);
  double* ap = joint_transforms.data_ptr<double>();
  for (int k = 0; k < kRigJoints; ++k) {
    double* a = ap + 16 * k;
    for (int i = 0; i < 3; ++i) {
      double rotated_rest = 0.0;
      for (int j = 0; j < 3; ++j) {
        a[4 * i + j] = global[k][4 * i + j];
        rotated_rest += global[k][4 * i + j] * rest[k][j];
      }
      a[4 * i + 3] = global[k][4 * i + 3] - rotated_rest + tp[i];
    }
    a[15] = 1.0;
  }

  // Skinning: T_v = sum_k w_vk A_k, v = T_v[:3, :3] v_posed + T_v[:3, 3].
  auto vertex_transforms = torch::empty({1, nv, 4, 4}, torch::kFloat64);
  auto vertices = torch::empty({1, nv, 3}, torch::kFloat64);
  double* vtp = vertex_transforms.data_ptr<double>();
  double* vp = vertices.data_ptr<double>();
  at::parallel_for(0, nv, kVertexGrain, [&](int64_t begin, int64_t end) {
    for (int64_t v = begin; v < end; ++v) {
      // Joint by joint, the 16 entries side by side (each still summed over k in order).
      double t[16] = {};
      for (int k = 0; k < kRigJoints; ++k) {
        const double w = wp[v * kRigJoints + k];
        for (int e = 0; e < 16; ++e) t[e] += w * ap[16 * k + e];
      }
      for (int e = 0; e < 16; ++e) vtp[16 * v + e] = t[e];
      for (int i = 0; i < 3; ++i)
        vp[3 * v + i] = t[4 * i] * vpp[3 * v] + t[4 * i + 1] * vpp[3 * v + 1] +
                        t[4 * i + 2] * vpp[3 * v + 2] + t[4 * i + 3];
    }
  });

  // MANO21 joints: the 16 posed joints (translated), then the five tip vertices.
  auto joints = torch::empty({1, 21, 3}, torch::kFloat64);
  auto rest_joints = torch::empty({1, 21, 3}, torch::kFloat64);
  double* jp = joints.data_ptr<double>();
  double* rjp = rest_joints.data_ptr<double>();
  for (int k = 0; k < kRigJoints; ++k)
    for (int c = 0; c < 3; ++c) {
      jp[3 * k + c] = global[k][4 * c + 3] + tp[c];
      rjp[3 * k + c] = rest[k][c];
    }
  for (int t = 0; t < 5; ++t) {
    const int64_t tip = rig.tip_vertices[t];
    TORCH_CHECK(tip >= 0 && tip < nv, "lbs_one_pose: tip vertex ", tip, " outside the rig's ", nv,
                " vertices");
    for (int c = 0; c < 3; ++c) {
      jp[3 * (kRigJoints + t) + c] = vp[3 * tip + c];
      rjp[3 * (kRigJoints + t) + c] = vsp[3 * tip + c];
    }
  }

  LbsOutput out;
  out.vertices = vertices.to(dtype);
  out.joints = joints.to(dtype);
  out.rest_joints = rest_joints.to(dtype);
  out.joint_transforms = joint_transforms.to(dtype);
  out.blend_offsets = (v_posed - tmpl.unsqueeze(0)).to(dtype);
  out.shape_offsets = (v_shaped - tmpl.unsqueeze(0)).to(dtype);
  out.vertex_transforms = vertex_transforms.to(dtype);
  return out;
}

}  // namespace handscs
