// Mirroring a synthetic capture through x = 0: see mirror.h.
#include "synth/mirror.h"

namespace handscs {

InterHandCamera mirror_interhand_camera(const InterHandCamera& raw, int width) {
  InterHandCamera out = raw;
  out.campos_mm[0] = -raw.campos_mm[0];
  // (M R M)_ij = m_i R_ij m_j with m = (-1, 1, 1): row 0 and column 0 flip, their corner twice.
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if ((i == 0) != (j == 0)) out.camrot[i * 3 + j] = -raw.camrot[i * 3 + j];
  out.princpt[0] = width - raw.princpt[0];
  return out;
}

std::array<double, 48> mirror_mano_pose(const std::array<double, 48>& pose) {
  std::array<double, 48> out = pose;
  for (int joint = 0; joint < 16; ++joint) {
    out[joint * 3 + 1] = -pose[joint * 3 + 1];
    out[joint * 3 + 2] = -pose[joint * 3 + 2];
  }
  return out;
}

std::array<double, 3> mirror_point(const std::array<double, 3>& point) {
  return {-point[0], point[1], point[2]};
}

std::array<double, 4> mirror_box(const std::array<double, 4>& box, int width) {
  return {width - box[0] - box[2], box[1], box[2], box[3]};
}

}  // namespace handscs
