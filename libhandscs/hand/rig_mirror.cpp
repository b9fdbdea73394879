// Mirror image of a rig through x = 0: see rig_mirror.h.
#include "hand/rig_mirror.h"

#include <ATen/ATen.h>

namespace handscs {

Rig mirror_rig(const Rig& rig) {
  const auto f64 = torch::kFloat64;
  const torch::Tensor m = torch::tensor({-1.0, 1.0, 1.0}, f64);  // x -> -x
  Rig out = rig;
  out.handedness = other_hand(rig.handedness);
  out.v_template = rig.v_template.to(f64) * m;
  // Swapping two corners re-winds each face: mirroring reverses orientation.
  out.faces = rig.faces.index_select(1, torch::tensor({0, 2, 1}, torch::kInt64)).contiguous();
  out.weights = rig.weights.clone();
  out.j_regressor = rig.j_regressor.clone();
  out.shapedirs = rig.shapedirs.to(f64) * m.view({1, 3, 1});
  // Pose feature entry (j, r, s) changes sign by m_r m_s, the offset's coordinate c by m_c.
  const torch::Tensor feature_sign =
      (m.view({3, 1}) * m.view({1, 3})).reshape({1, 9}).repeat({15, 1});
  out.posedirs = rig.posedirs.to(f64) * m.view({1, 3, 1}) * feature_sign.reshape({1, 1, 135});
  // Axis-angle of M R M (M = diag(-1, 1, 1)) is (a, -b, -c).
  const torch::Tensor axis_sign = torch::tensor({1.0, -1.0, -1.0}, f64).repeat({15});
  out.hands_mean = rig.hands_mean.to(f64) * axis_sign;
  if (rig.vertex_labels.defined()) out.vertex_labels = rig.vertex_labels.clone();
  return out;
}

}  // namespace handscs
