// Differentiable batched LBS (MANO) built from LibTorch ops: autograd provides the backward pass.
//   v_shaped = T + S beta, J = J_reg v_shaped, v_posed = v_shaped + P (R - I),
//   G_k = G_parent(k) [R_k | J_k - J_parent(k)], A_k = G_k [I | -J_k] (+ trans), v = sum_k w_k A_k
//   v_posed.
#include "hand/lbs.h"

#include <ATen/ATen.h>

#include "hand/joint_order.h"

namespace handscs {

namespace {

// Below this squared angle the Taylor series replace sin(t)/t and (1 - cos t)/t^2: the series'
// first dropped term (t^6/5040) is below the dtype's rounding there, and the sqrt of t^2 is never
// taken at zero, so value and gradient stay finite at exactly zero angle.
double taylor_threshold(c10::ScalarType dtype) { return dtype == torch::kFloat64 ? 1e-4 : 1e-2; }

}  // namespace

torch::Tensor rodrigues(const torch::Tensor& axis_angle) {  // [..., 3] -> [..., 3, 3]
  TORCH_CHECK(axis_angle.dim() >= 1 && axis_angle.size(-1) == 3,
              "rodrigues: expected axis-angle [..., 3], got ", axis_angle.sizes());
  TORCH_CHECK(
      axis_angle.scalar_type() == torch::kFloat32 || axis_angle.scalar_type() == torch::kFloat64,
      "rodrigues: expected float32 or float64, got ", axis_angle.scalar_type());
  const torch::Tensor x = axis_angle.select(-1, 0);
  const torch::Tensor y = axis_angle.select(-1, 1);
  const torch::Tensor z = axis_angle.select(-1, 2);
  const torch::Tensor t2 = x * x + y * y + z * z;
  const torch::Tensor small = t2 < taylor_threshold(axis_angle.scalar_type());
  // The large-angle branch sees t^2 = 1 where the series is used, so it never divides by zero.
  const torch::Tensor t2_safe = torch::where(small, torch::ones_like(t2), t2);
  const torch::Tensor t = t2_safe.sqrt();
  const torch::Tensor half = 0.5 * t;
  const torch::Tensor sinc_half = half.sin() / half;
  // a = sin(t)/t, b = (1 - cos t)/t^2 = sinc(t/2)^2 / 2 (no cancellation at small t).
  const torch::Tensor a_large = t.sin() / t;
  const torch::Tensor b_large = 0.5 * sinc_half * sinc_half;
  const torch::Tensor a_small = 1.0 - t2 / 6.0 + t2 * t2 / 120.0;
  const torch::Tensor b_small = 0.5 - t2 / 24.0 + t2 * t2 / 720.0;
  const torch::Tensor a = torch::where(small, a_small, a_large);
  const torch::Tensor b = torch::where(small, b_small, b_large);
  // R = I + a K + b K^2 with K = [v]_x and K^2 = v v^T - t^2 I.
  const torch::Tensor r00 = 1.0 + b * (x * x - t2);
  const torch::Tensor r11 = 1.0 + b * (y * y - t2);
  const torch::Tensor r22 = 1.0 + b * (z * z - t2);
  const torch::Tensor bxy = b * x * y, bxz = b * x * z, byz = b * y * z;
  const torch::Tensor ax = a * x, ay = a * y, az = a * z;
  const torch::Tensor entries =
      torch::stack({r00, bxy - az, bxz + ay, bxy + az, r11, byz - ax, bxz - ay, byz + ax, r22}, -1);
  std::vector<int64_t> shape(axis_angle.sizes().begin(), axis_angle.sizes().end());
  shape.back() = 3;
  shape.push_back(3);
  return entries.reshape(shape);
}

LbsOutput lbs(const Rig& rig, const torch::Tensor& pose,  // [B, 48]
              const torch::Tensor& shape,                 // [B, 10]
              const torch::Tensor& trans,                 // [B, 3]
              const LbsOptions& options) {
  TORCH_CHECK(rig.v_template.defined() && rig.v_template.dim() == 2,
              "lbs: the rig has no template (load it with load_rig or load_rig_source)");
  TORCH_CHECK(pose.dim() == 2 && pose.size(1) == kPoseDim, "lbs: expected pose [B, 48], got ",
              pose.sizes());
  TORCH_CHECK(pose.scalar_type() == torch::kFloat32 || pose.scalar_type() == torch::kFloat64,
              "lbs: expected a float32 or float64 pose, got ", pose.scalar_type());
  const int64_t batch = pose.size(0);
  TORCH_CHECK(shape.dim() == 2 && shape.size(0) == batch && shape.size(1) == kShapeDim,
              "lbs: expected shape [", batch, ", 10], got ", shape.sizes());
  TORCH_CHECK(trans.dim() == 2 && trans.size(0) == batch && trans.size(1) == 3,
              "lbs: expected trans [", batch, ", 3], got ", trans.sizes());
  TORCH_CHECK(rig.parents.size() == kRigJoints, "lbs: the rig needs 16 parents, got ",
              rig.parents.size());
  const int64_t num_vertices = rig.num_vertices();
  const auto dtype = pose.scalar_type();
  const auto float_options = pose.options();

  const torch::Tensor beta = shape.to(dtype);
  const torch::Tensor translation = trans.to(dtype);
  const torch::Tensor v_template = rig.v_template.to(dtype);  // [V, 3]
  const torch::Tensor shapedirs = rig.shapedirs.to(dtype).reshape({num_vertices * 3, kShapeDim});
  const torch::Tensor posedirs =
      rig.posedirs.to(dtype).reshape({num_vertices * 3, kPoseFeatureDim});
  const torch::Tensor j_regressor = rig.j_regressor.to(dtype);  // [16, V]
  const torch::Tensor weights = rig.weights.to(dtype);          // [V, 16]

  // Shape: v_shaped [B, V, 3], rest joints J [B, 16, 3].
  const torch::Tensor v_shaped =
      v_template.unsqueeze(0) + torch::matmul(beta, shapedirs.t()).view({batch, num_vertices, 3});
  const torch::Tensor rest = torch::matmul(j_regressor, v_shaped);

  // Pose: rotations [B, 16, 3, 3] and the 135-D pose feature (R_j - I, finger joints).
  torch::Tensor full_pose = pose;
  if (!options.flat_hand_mean)
    full_pose = torch::cat(
        {pose.slice(1, 0, 3), pose.slice(1, 3) + rig.hands_mean.to(dtype).unsqueeze(0)}, 1);
  const torch::Tensor rotations = rodrigues(full_pose.view({batch, kRigJoints, 3}));
  const torch::Tensor eye = torch::eye(3, float_options);
  const torch::Tensor feature = (rotations.slice(1, 1) - eye).reshape({batch, kPoseFeatureDim});
  const torch::Tensor v_posed =
      v_shaped + torch::matmul(feature, posedirs.t()).view({batch, num_vertices, 3});

  // Kinematic chain: G_k = G_parent [R_k | J_k - J_parent] (parents precede children).
  const torch::Tensor bottom =
      torch::tensor({0.0, 0.0, 0.0, 1.0}, float_options).view({1, 1, 4}).expand({batch, 1, 4});
  std::vector<torch::Tensor> chain(kRigJoints);
  for (int k = 0; k < kRigJoints; ++k) {
    const int64_t parent = rig.parents[k];
    TORCH_CHECK(parent < k, "lbs: joint ", k, " has parent ", parent, " (parents must come first)");
    const torch::Tensor offset =
        parent < 0 ? rest.select(1, k) : rest.select(1, k) - rest.select(1, parent);
    const torch::Tensor local =
        torch::cat({torch::cat({rotations.select(1, k), offset.unsqueeze(-1)}, -1), bottom}, 1);
    chain[k] = parent < 0 ? local : torch::matmul(chain[parent], local);
  }
  const torch::Tensor global = torch::stack(chain, 1);                         // [B, 16, 4, 4]
  const torch::Tensor global_rotation = global.slice(2, 0, 3).slice(3, 0, 3);  // [B, 16, 3, 3]
  const torch::Tensor posed_joints = global.slice(2, 0, 3).select(3, 3);       // [B, 16, 3]

  // A_k = G_k with the rest joint removed, then translated: maps rest-space points to world.
  const torch::Tensor a_translation =
      posed_joints - torch::matmul(global_rotation, rest.unsqueeze(-1)).squeeze(-1) +
      translation.unsqueeze(1);
  const torch::Tensor joint_transforms =
      torch::cat({torch::cat({global_rotation, a_translation.unsqueeze(-1)}, -1),
                  bottom.unsqueeze(1).expand({batch, kRigJoints, 1, 4})},
                 2);

  // Skinning: per-vertex blend transforms [B, V, 4, 4], posed vertices [B, V, 3].
  const torch::Tensor vertex_transforms =
      torch::matmul(weights, joint_transforms.reshape({batch, kRigJoints, 16}))
          .view({batch, num_vertices, 4, 4});
  const torch::Tensor vertices =
      torch::matmul(vertex_transforms.slice(2, 0, 3).slice(3, 0, 3), v_posed.unsqueeze(-1))
          .squeeze(-1) +
      vertex_transforms.slice(2, 0, 3).select(3, 3);

  const torch::Tensor tips = torch::tensor(
      std::vector<int64_t>(rig.tip_vertices.begin(), rig.tip_vertices.end()), torch::kInt64);
  LbsOutput out;
  out.vertices = vertices;
  out.joints =
      torch::cat({posed_joints + translation.unsqueeze(1), vertices.index_select(1, tips)}, 1);
  out.rest_joints = torch::cat({rest, v_shaped.index_select(1, tips)}, 1);
  out.joint_transforms = joint_transforms;
  out.blend_offsets = v_posed - v_template.unsqueeze(0);
  out.shape_offsets = v_shaped - v_template.unsqueeze(0);
  out.vertex_transforms = vertex_transforms;
  return out;
}

}  // namespace handscs
