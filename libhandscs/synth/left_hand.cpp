// The reflected left hand of a two-hand synthetic capture: see left_hand.h.
#include "synth/left_hand.h"

#include <cmath>

#include "core/error.h"
#include "hand/lbs.h"
#include "hand/so3.h"
#include "synth/mirror.h"

namespace handscs {

namespace {

// Largest gap allowed between the left rig's mesh and the reflected one: float vertices of a hand
// 1 m from the origin round at ~1e-7 m, so anything near 0.1 mm is a wrong convention, not rounding.
constexpr double kMaxReflectionError = 1e-4;

void reflect_z(std::vector<float>& xyz) {
  for (size_t i = 2; i < xyz.size(); i += 3) xyz[i] = -xyz[i];
}

}  // namespace

std::array<double, 48> reflected_left_pose(const std::array<double, 48>& right_pose) {
  std::array<double, 48> out = mirror_mano_pose(right_pose);
  const Mat3 turn = {-1, 0, 0, 0, 1, 0, 0, 0, -1};  // R_y(pi)
  const Vec3 global = rotation_log(mat_mul(turn, rodrigues_one(out.data())));
  for (int d = 0; d < 3; ++d) out[d] = global[d];
  return out;
}

void reflect_geometry(SynthFrame& frame) {
  reflect_z(frame.vertices);
  reflect_z(frame.normals);
  reflect_z(frame.forearm);
  reflect_z(frame.forearm_normals);
  for (int j = 0; j < 21; ++j) frame.joints[j * 3 + 2] = -frame.joints[j * 3 + 2];
}

void annotate_left_hands(const Rig& left_rig, std::vector<SynthFrame>& frames) {
  const int64_t n = static_cast<int64_t>(frames.size());
  if (n == 0) return;
  const auto options = torch::TensorOptions().dtype(torch::kFloat64);
  torch::Tensor pose = torch::empty({n, 48}, options), shape = torch::empty({n, 10}, options);
  for (int64_t k = 0; k < n; ++k) {
    const std::array<double, 48> left = reflected_left_pose(frames[k].absolute.pose);
    std::copy(left.begin(), left.end(), pose[k].data_ptr<double>());
    std::copy(frames[k].absolute.shape.begin(), frames[k].absolute.shape.end(),
              shape[k].data_ptr<double>());
  }
  torch::NoGradGuard no_grad;
  LbsOptions lbs_options;
  lbs_options.flat_hand_mean = true;
  const torch::Tensor rig_vertices =
      lbs(left_rig, pose, shape, torch::zeros({n, 3}, options), lbs_options).vertices.contiguous();
  const int64_t num_vertices = rig_vertices.size(1);
  for (int64_t k = 0; k < n; ++k) {
    SynthFrame& frame = frames[k];
    require(static_cast<int64_t>(frame.vertices.size()) == num_vertices * 3,
            "synth: the left rig's vertex count differs from the right hand's");
    const double* rig = rig_vertices[k].data_ptr<double>();
    std::array<double, 3> trans{};
    for (int64_t i = 0; i < num_vertices; ++i)
      for (int d = 0; d < 3; ++d) {
        const double target = (d == 2 ? -1.0 : 1.0) * frame.vertices[i * 3 + d];
        trans[d] += (target - rig[i * 3 + d]) / static_cast<double>(num_vertices);
      }
    double worst = 0;
    for (int64_t i = 0; i < num_vertices; ++i)
      for (int d = 0; d < 3; ++d) {
        const double target = (d == 2 ? -1.0 : 1.0) * frame.vertices[i * 3 + d];
        worst = std::max(worst, std::abs(target - rig[i * 3 + d] - trans[d]));
      }
    if (worst > kMaxReflectionError)
      throw Error("synth: the left rig misses the reflected right hand by " +
                  std::to_string(worst * 1e3) + " mm (frame " + std::to_string(k) + ")");
    // The fit error as drawn for the right hand, carried through the same reflection.
    std::array<double, 3> error{};
    for (int d = 0; d < 3; ++d)
      error[d] = (d == 2 ? -1.0 : 1.0) * (frame.annotated_trans[d] - frame.trans[d]);
    frame.absolute.pose = reflected_left_pose(frame.absolute.pose);
    frame.annotated = reflected_left_pose(frame.annotated);
    frame.trans = trans;
    for (int d = 0; d < 3; ++d) frame.annotated_trans[d] = trans[d] + error[d];
  }
}

}  // namespace handscs
