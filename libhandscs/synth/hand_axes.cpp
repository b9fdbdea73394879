#include "synth/hand_axes.h"

#include "hand/joint_order.h"
#include "synth/tensor_row.h"

namespace handscs {

using namespace synth;

namespace {

}  // namespace

HandAxes rig_axes(const Rig& rig) {
  const torch::Tensor vt = rig.v_template.to(torch::kFloat64).contiguous();
  const torch::Tensor joints = torch::matmul(rig.j_regressor.to(torch::kFloat64), vt).contiguous();
  auto J = [&](int k) { return tensor_row(joints, k); };
  auto tip = [&](int f) { return tensor_row(vt, rig.tip_vertices[f]); };
  HandAxes axes;
  const Vec3 wrist = J(0);
  const Vec3 knuckles = (J(1) + J(4) + J(10) + J(7)) * 0.25;
  axes.long_axis = normalized(knuckles - wrist);
  Vec3 n = normalized(cross(J(1) - wrist, J(7) - wrist));
  // Orient the palm normal towards the palmar side: from the labels when present (palmar skin
  // label 2), else from handedness (right hand: palm normal = thumb side x finger direction).
  bool oriented = false;
  if (rig.vertex_labels.defined() && rig.vertex_labels.numel() == rig.num_vertices()) {
    const torch::Tensor labels = rig.vertex_labels.to(torch::kInt64).contiguous();
    const torch::Tensor palmar = labels.eq(2);
    if (palmar.any().item<bool>()) {
      const torch::Tensor c_palmar = vt.index({palmar}).mean(0).contiguous();
      const torch::Tensor c_all = vt.mean(0).contiguous();
      const Vec3 towards = tensor_row(c_palmar.unsqueeze(0), 0) - tensor_row(c_all.unsqueeze(0), 0);
      if (dot(n, towards) < 0) n = n * -1.0;
      oriented = true;
    }
  }
  if (!oriented) {
    const Vec3 thumb_side = J(13) - knuckles;
    Vec3 expected = normalized(cross(thumb_side, axes.long_axis));
    if (rig.handedness == Handedness::left) expected = expected * -1.0;
    if (dot(n, expected) < 0) n = n * -1.0;
  }
  axes.palm_normal = n;
  axes.wrist_flex = normalized(cross(axes.long_axis, n));

  // Thumb palmar direction: opposite to its nail (labels 1 weighted mostly by thumb joints).
  Vec3 thumb_palmar = n;
  if (rig.vertex_labels.defined() && rig.vertex_labels.numel() == rig.num_vertices()) {
    const torch::Tensor labels = rig.vertex_labels.to(torch::kInt64).contiguous();
    const torch::Tensor owner = rig.weights.argmax(1).contiguous();
    const Vec3 base = J(15), dir = normalized(tip(kThumb) - J(15));
    Vec3 sum{0, 0, 0};
    int count = 0;
    for (int64_t v = 0; v < rig.num_vertices(); ++v) {
      const int64_t o = owner[v].item<int64_t>();
      if (labels[v].item<int64_t>() != 1 || (o != 13 && o != 14 && o != 15)) continue;
      const Vec3 offset = tensor_row(vt, v) - base;
      sum = sum + (offset - dir * dot(offset, dir));
      ++count;
    }
    if (count > 0) thumb_palmar = normalized(sum) * -1.0;
  }
  axes.thumb_palmar = thumb_palmar;

  for (int f = 0; f < kFingers; ++f) {
    const auto& chain = kFingerJoints[f];
    const Vec3 dirs[3] = {J(chain[1]) - J(chain[0]), J(chain[2]) - J(chain[1]),
                          tip(f) - J(chain[2])};
    const Vec3 palmar = f == kThumb ? thumb_palmar : n;
    // Rotating bone d about (d x palmar) moves its end towards the palmar side.
    for (int k = 0; k < 3; ++k) axes.flex[f][k] = normalized(cross(dirs[k], palmar));
    if (f != kThumb && f != kMiddle) {
      const Vec3 side = J(chain[0]) - J(kFingerJoints[kMiddle][0]);
      axes.spread_sign[f] = dot(cross(n, dirs[0]), side) > 0 ? 1.0 : -1.0;
    }
  }
  const Vec3 thumb_reach = tip(kThumb) - J(13);
  axes.opposition_sign = dot(cross(axes.long_axis, thumb_reach), n) > 0 ? 1.0 : -1.0;
  return axes;
}


}  // namespace handscs
