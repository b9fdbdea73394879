// The built-in hand with per-finger length modes: modes 7-9 are mode 1 split by finger, each moves
// its own finger's joints alone, the left variant mirrors the right, and joints made with a
// shorter ring and a longer pinky fit back only with the modes.
#include <catch2/catch.hpp>

#include "hand/finger_length_modes.h"
#include "hand/joint_model.h"
#include "hand/joint_order.h"
#include "hand/keypoint_fit.h"
#include "hand/rig.h"

using namespace handscs;

namespace {

std::array<double, 63> joints_at(const JointModel& model, const JointParams& p) {
  std::array<double, 63> x;
  joint_positions(model, p, x.data());
  return x;
}

double bone_length(const std::array<double, 63>& x, int a, int b) {
  return std::hypot(x[3 * a] - x[3 * b], x[3 * a + 1] - x[3 * b + 1], x[3 * a + 2] - x[3 * b + 2]);
}

}  // namespace

TEST_CASE("builtin+fingers: modes 7-9 split mode 1 by finger and leave modes 0-6 as they were") {
  const Rig plain = load_rig_source("builtin");
  const Rig fingers = load_rig_source(kBuiltinFingersRig);
  CHECK(fingers.name == kBuiltinFingersRig);
  CHECK(torch::equal(fingers.shapedirs.narrow(2, 0, 7), plain.shapedirs.narrow(2, 0, 7)));
  CHECK(torch::equal(plain.shapedirs.narrow(2, 7, 3), torch::zeros_like(plain.shapedirs.narrow(2, 7, 3))));
  // Each vertex's new modes are zero or its mode 1, at most one of them non-zero.
  const auto mode1 = fingers.shapedirs.select(2, 1);
  int64_t moved = 0;
  const auto rows_moved_by_new_modes = (fingers.shapedirs.narrow(2, 7, 3).abs().sum(1) > 0).sum(1);  // [V]
  CHECK(rows_moved_by_new_modes.max().item<int64_t>() == 1);
  for (int mode = 7; mode < 10; ++mode) {
    const auto m = fingers.shapedirs.select(2, mode);
    const auto rows = m.abs().sum(1) > 0;
    moved += rows.sum().item<int64_t>();
    CHECK(torch::equal(m.index({rows}), mode1.index({rows})));
  }
  const int64_t mode1_rows = (mode1.abs().sum(1) > 0).sum().item<int64_t>();
  CHECK(moved > mode1_rows / 2);   // three of four fingers
  CHECK(moved < mode1_rows);       // the middle finger keeps mode 1 alone
}

TEST_CASE("builtin+fingers: a finger's mode lengthens that finger's bones by 6 % and moves no other joint") {
  const JointModel model = make_joint_model(load_rig_source(kBuiltinFingersRig));
  JointParams rest;
  const auto before = joints_at(model, rest);
  for (const auto& [mode, finger] : {std::pair{7, kIndex}, std::pair{8, kRing}, std::pair{9, kPinky}}) {
    JointParams p;
    p.shape[mode] = 1.0;
    const auto after = joints_at(model, p);
    INFO("mode " << mode);
    const auto& chain = kFingerJoints[finger];
    for (int j = 0; j < 21; ++j) {
      const bool own = j == chain[1] || j == chain[2] || j == kTipJoint0 + finger;
      if (own) continue;
      INFO("joint " << kMano21Names[j]);
      CHECK(std::fabs(after[3 * j] - before[3 * j]) + std::fabs(after[3 * j + 1] - before[3 * j + 1]) +
                std::fabs(after[3 * j + 2] - before[3 * j + 2]) < 1e-12);
    }
    // The bones after the knuckle grow by the mode's 6 %, within what the ring-average joints allow.
    for (const auto& [a, b] : {std::pair{chain[0], chain[1]}, std::pair{chain[1], chain[2]}}) {
      const double ratio = bone_length(after, a, b) / bone_length(before, a, b);
      CHECK(ratio == Approx(1.06).margin(0.01));
    }
  }
}

TEST_CASE("builtin+fingers:left mirrors the right hand, modes included") {
  const JointModel right = make_joint_model(load_rig_source(kBuiltinFingersRig));
  const JointModel left = make_joint_model(load_rig_source(kBuiltinFingersLeftRig));
  JointParams p;
  p.shape = {0.5, -0.3, 0.2, 0, 0, 0.1, 0.4, 1.5, -2.0, 1.0};
  const auto r = joints_at(right, p), l = joints_at(left, p);
  for (int j = 0; j < 21; ++j) {
    CHECK(l[3 * j] == Approx(-r[3 * j]).margin(1e-12));
    CHECK(l[3 * j + 1] == Approx(r[3 * j + 1]).margin(1e-12));
    CHECK(l[3 * j + 2] == Approx(r[3 * j + 2]).margin(1e-12));
  }
}

TEST_CASE("builtin+fingers: a shorter ring and a longer pinky fit back with the modes, not without") {
  const JointModel fingers = make_joint_model(load_rig_source(kBuiltinFingersRig));
  const JointModel plain = make_joint_model(load_rig_source("builtin"));
  JointParams truth;
  truth.shape[8] = -2.0;  // ring 12 % shorter
  truth.shape[9] = 2.0;   // pinky 12 % longer
  truth.trans = {0.0, 0.0, 0.8};
  HandKeypoints k;
  k.joints = joints_at(fingers, truth);
  k.valid.fill(1);
  const KeypointFitConfig config;
  const HandFit with = fit_keypoints(fingers, k, config);
  const HandFit without = fit_keypoints(plain, k, config);
  CHECK(with.mean_mm < 0.05);
  CHECK(with.params.shape[8] == Approx(-2.0).margin(0.05));
  CHECK(with.params.shape[9] == Approx(2.0).margin(0.05));
  CHECK(without.mean_mm > 10 * with.mean_mm);
}
