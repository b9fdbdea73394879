#include "hand/finger_length_modes.h"

#include "hand/joint_order.h"

namespace handscs {

namespace {

constexpr int kFingerLengthMode = 1;  // the built-in hand's length of index..pinky
// The fingers that get a mode of their own, and their modes; the middle finger follows mode 1.
constexpr std::array<std::pair<Finger, int>, 3> kFingerModes = {{{kIndex, 7}, {kRing, 8}, {kPinky, 9}}};

}  // namespace

Rig with_finger_length_modes(Rig builtin) {
  const auto weights = builtin.weights.contiguous();  // [V, 16]
  auto shapedirs = builtin.shapedirs.clone();         // [V, 3, 10]
  const int64_t V = weights.size(0);
  const auto w = weights.accessor<double, 2>();
  auto s = shapedirs.accessor<double, 3>();
  for (int64_t v = 0; v < V; ++v) {
    if (s[v][0][kFingerLengthMode] == 0 && s[v][1][kFingerLengthMode] == 0 && s[v][2][kFingerLengthMode] == 0)
      continue;  // mode 1 leaves it (palm, thumb, the rings shared with the palm)
    int finger = -1;
    double heaviest = 0;
    for (int f = 0; f < kFingers; ++f) {
      double sum = 0;
      for (int joint : kFingerJoints[f]) sum += w[v][joint];
      if (sum > heaviest) {
        heaviest = sum;
        finger = f;
      }
    }
    for (const auto& [f, mode] : kFingerModes)
      if (finger == f)
        for (int c = 0; c < 3; ++c) s[v][c][mode] = s[v][c][kFingerLengthMode];
  }
  builtin.shapedirs = shapedirs;
  builtin.name = kBuiltinFingersRig;
  return builtin;
}

}  // namespace handscs
