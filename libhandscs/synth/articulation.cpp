#include "synth/articulation.h"

#include <algorithm>

#include "hand/joint_order.h"

namespace handscs {

using namespace synth;

std::array<double, 48> articulate(const HandAxes& axes, const HandArticulation& a) {
  std::array<Mat3, 16> local;
  local.fill(identity3());
  local[0] = mul(mul(rotation(axes.long_axis, a.pronation), rotation(axes.wrist_flex, a.wrist_flex)),
                 rotation(axes.palm_normal, a.wrist_deviation));
  for (int f = 1; f < kFingers; ++f) {
    const auto& chain = kFingerJoints[f];
    local[chain[0]] = mul(rotation(axes.flex[f][0], a.flex[f][0]),
                          rotation(axes.palm_normal, axes.spread_sign[f] * a.spread[f]));
    local[chain[1]] = rotation(axes.flex[f][1], a.flex[f][1]);
    local[chain[2]] = rotation(axes.flex[f][2], a.flex[f][2]);
  }
  const auto& thumb = kFingerJoints[kThumb];
  local[thumb[0]] = mul(rotation(axes.long_axis, axes.opposition_sign * a.thumb_opposition),
                        rotation(axes.flex[kThumb][0], a.flex[kThumb][0]));
  local[thumb[1]] = rotation(axes.flex[kThumb][1], a.flex[kThumb][1]);
  local[thumb[2]] = rotation(axes.flex[kThumb][2], a.flex[kThumb][2]);
  std::array<double, 48> pose{};
  for (int j = 0; j < 16; ++j) {
    const Vec3 aa = axis_angle(local[j]);
    for (int d = 0; d < 3; ++d) pose[j * 3 + d] = aa[d];
  }
  return pose;
}

double palm_fold(const HandArticulation& a) {
  double mcp_mean = 0;
  for (int f = 1; f < kFingers; ++f) mcp_mean += std::clamp(a.flex[f][0] / kFlexionUnit, 0.0, 1.0) / 4;
  const double opposition = std::clamp(a.thumb_opposition / kFullOpposition, 0.0, 1.0);
  return 0.6 * mcp_mean + 0.4 * opposition;
}

}  // namespace handscs
