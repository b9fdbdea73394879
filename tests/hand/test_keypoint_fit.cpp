// The keypoint fit's parts against independent references: the joint model against lbs_one_pose,
// its Jacobian against central finite differences, the SO(3) helpers against their definitions,
// and the fit itself by round trips (pose -> rig joints -> fit -> joints).
#include <catch2/catch.hpp>

#include <cmath>
#include <random>

#include "core/symmetric_eigen.h"
#include "hand/joint_model.h"
#include "hand/joint_order.h"
#include "hand/keypoint_fit.h"
#include "hand/keypoint_order.h"
#include "hand/lbs_one_pose.h"
#include "hand/procedural_hand.h"
#include "hand/so3.h"
#include "rig_fixtures.h"

using namespace handscs;

namespace {

JointParams random_params(std::mt19937& rng, double pose_scale) {
  std::normal_distribution<double> n(0.0, 1.0);
  JointParams p;
  for (double& v : p.pose) v = n(rng) * pose_scale;
  for (double& v : p.trans) v = n(rng) * 0.1;
  for (double& v : p.shape) v = n(rng);
  return p;
}

// A plausible hand pose for `model`: each finger joint bent towards the palm (0 to 1.3 rad about
// its flexion axis), spread a little (knuckles +-0.15 rad, the other joints +-0.1) and twisted a
// little (+-0.15 rad about its bone, which joints cannot see); a random global rotation.
JointParams plausible_params(const JointModel& model, std::mt19937& rng) {
  std::uniform_real_distribution<double> bend(0.0, 1.3), spread(-0.15, 0.15), twist(-0.15, 0.15),
      any(-3.0, 3.0), shape(-1.5, 1.5);
  JointParams p;
  for (int i = 0; i < 3; ++i) p.pose[i] = any(rng) * 0.5;
  for (int k = 1; k < kRigJoints; ++k) {
    const Vec3 bone{model.child_axis[3 * k], model.child_axis[3 * k + 1], model.child_axis[3 * k + 2]};
    const Vec3 flex = normalized(cross(Vec3{0, 1, 0}, bone));
    const Vec3 back = cross(bone, flex);
    const bool thumb = k >= 13;
    const bool knuckle = k == 1 || k == 4 || k == 7 || k == 10 || k == 13;
    const Vec3 w = flex * (thumb ? bend(rng) * 0.5 : bend(rng)) + back * (spread(rng) * (knuckle ? 1.0 : 2.0 / 3.0)) +
                   bone * twist(rng);
    for (int i = 0; i < 3; ++i) p.pose[3 * k + i] = w[i];
  }
  for (int i = 0; i < 3; ++i) p.trans[i] = any(rng) * 0.1;
  for (int s = 0; s < 7; ++s) p.shape[s] = shape(rng);  // the built-in hand's 7 modes
  return p;
}

std::array<double, 63> joints_of(const JointModel& model, const JointParams& p) {
  std::array<double, 63> x;
  joint_positions(model, p, x.data());
  return x;
}

HandKeypoints all_valid(const std::array<double, 63>& joints) {
  HandKeypoints k;
  k.joints = joints;
  k.valid.fill(1);
  return k;
}

}  // namespace

TEST_CASE("so3: rodrigues, its right Jacobian and the logarithm agree with their definitions") {
  std::mt19937 rng(5);
  std::normal_distribution<double> n(0.0, 1.0);
  for (double scale : {1e-4, 0.3, 1.5, 3.0}) {
    for (int trial = 0; trial < 20; ++trial) {
      Vec3 v{n(rng) * scale, n(rng) * scale, n(rng) * scale};
      if (norm(v) > 3.1) v = normalized(v) * 3.1;
      const Mat3 R = rodrigues_one(v.data());
      const Vec3 back = rotation_log(R);
      CHECK(norm(back - v) < 1e-9);
      // R(v)^T R(v + h e_i) = exp([J_r e_i h]) to first order: central differences of the log.
      const Mat3 J = right_jacobian(v.data());
      const double h = 1e-6;
      for (int i = 0; i < 3; ++i) {
        Vec3 plus = v, minus = v;
        plus[i] += h;
        minus[i] -= h;
        const Vec3 d_plus = rotation_log(mat_mul(mat_transpose(R), rodrigues_one(plus.data())));
        const Vec3 d_minus = rotation_log(mat_mul(mat_transpose(R), rodrigues_one(minus.data())));
        for (int r = 0; r < 3; ++r) CHECK(std::fabs((d_plus[r] - d_minus[r]) / (2 * h) - J[3 * r + i]) < 1e-7);
      }
    }
  }
  // Near pi the logarithm keeps its accuracy.
  const Vec3 near_pi = normalized(Vec3{0.3, -0.5, 0.8}) * (M_PI - 1e-7);
  CHECK(norm(rotation_log(rodrigues_one(near_pi.data())) - near_pi) < 1e-6);
}

TEST_CASE("symmetric_eigen: A v = lambda v, ascending, unit vectors") {
  std::mt19937 rng(9);
  std::normal_distribution<double> n(0.0, 1.0);
  for (int size : {2, 4, 6}) {
    std::vector<double> a(size * size);
    for (int i = 0; i < size; ++i)
      for (int j = 0; j <= i; ++j) a[i * size + j] = a[j * size + i] = n(rng);
    std::vector<double> values, vectors;
    symmetric_eigen(a.data(), size, values, vectors);
    for (int e = 0; e < size; ++e) {
      if (e > 0) CHECK(values[e] >= values[e - 1]);
      double length = 0;
      for (int r = 0; r < size; ++r) {
        double av = 0;
        for (int c = 0; c < size; ++c) av += a[r * size + c] * vectors[e * size + c];
        CHECK(std::fabs(av - values[e] * vectors[e * size + r]) < 1e-10);
        length += vectors[e * size + r] * vectors[e * size + r];
      }
      CHECK(std::fabs(length - 1) < 1e-12);
    }
  }
}

TEST_CASE("joint model: the joints of lbs_one_pose, for a rig with pose blend shapes and the built-in hand") {
  const std::vector<Rig> rigs = {test::make_toy_rig(60, 4), make_procedural_hand(Handedness::right),
                                 make_procedural_hand(Handedness::left)};
  std::mt19937 rng(3);
  for (const Rig& rig : rigs) {
    const JointModel model = make_joint_model(rig);
    for (int trial = 0; trial < 5; ++trial) {
      const JointParams p = random_params(rng, trial == 0 ? 0.0 : 0.8);
      const auto x = joints_of(model, p);
      const auto f64 = torch::kFloat64;
      const LbsOutput ref = lbs_one_pose(rig, torch::tensor(std::vector<double>(p.pose.begin(), p.pose.end()), f64),
                                         torch::tensor(std::vector<double>(p.shape.begin(), p.shape.end()), f64),
                                         torch::tensor(std::vector<double>(p.trans.begin(), p.trans.end()), f64),
                                         LbsOptions{true});
      const auto ref_joints = ref.joints.reshape({63}).contiguous();
      double worst = 0;
      for (int i = 0; i < 63; ++i) worst = std::max(worst, std::fabs(x[i] - ref_joints[i].item<double>()));
      INFO("rig " << rig.name << " trial " << trial);
      CHECK(worst < 1e-12);
    }
  }
}

TEST_CASE("joint model: the Jacobian matches central finite differences in every column") {
  const std::vector<Rig> rigs = {test::make_toy_rig(60, 8), make_procedural_hand(Handedness::right)};
  std::mt19937 rng(11);
  for (const Rig& rig : rigs) {
    const JointModel model = make_joint_model(rig);
    // Away from zero angles (the series branch is exact too, but differences there straddle it).
    const JointParams p = random_params(rng, 0.6);
    std::vector<double> jac(63 * kJointParams);
    std::array<double, 63> x;
    joint_positions(model, p, x.data(), jac.data());
    const double h = 1e-6;  // central differences: error ~h^2 * curvature, rounding ~1e-16 / h
    double worst = 0;
    for (int col = 0; col < kJointParams; ++col) {
      JointParams plus = p, minus = p;
      auto bump = [&](JointParams& q, double d) {
        if (col < kPoseDim) q.pose[col] += d;
        else if (col < kShapeColumn) q.trans[col - kTransColumn] += d;
        else q.shape[col - kShapeColumn] += d;
      };
      bump(plus, h);
      bump(minus, -h);
      const auto xp = joints_of(model, plus), xm = joints_of(model, minus);
      for (int r = 0; r < 63; ++r)
        worst = std::max(worst, std::fabs((xp[r] - xm[r]) / (2 * h) - jac[r * kJointParams + col]));
    }
    INFO("rig " << rig.name);
    CHECK(worst < 1e-8);
  }
}

TEST_CASE("keypoint orders: each maps to MANO21 and back without loss") {
  for (const std::string name : {"mano21", "interhand", "mediapipe", "openpose"}) {
    const auto index = mano21_from_order(keypoint_order_from_name(name, "test"));
    std::array<int, 21> seen{};
    for (int i : index) seen.at(i) += 1;
    for (int count : seen) CHECK(count == 1);
  }
  // InterHand's row 20 is the wrist, MediaPipe's row 0; both name MANO21 joint 0.
  CHECK(mano21_from_order(KeypointOrder::interhand)[0] == 20);
  CHECK(mano21_from_order(KeypointOrder::mediapipe)[0] == 0);
  // The thumb tip: InterHand row 0, MediaPipe row 4, MANO21 16.
  CHECK(mano21_from_order(KeypointOrder::interhand)[16] == 0);
  CHECK(mano21_from_order(KeypointOrder::mediapipe)[16] == 4);
  CHECK_THROWS_WITH(keypoint_order_from_name("coco", "keypoints.json: order"),
                    Catch::Contains("keypoints.json: order: unknown keypoint order \"coco\""));
}

TEST_CASE("keypoint fit: noise-free round trip recovers the joints and every bend angle") {
  for (Handedness hand : {Handedness::right, Handedness::left}) {
    const JointModel model = make_joint_model(make_procedural_hand(hand));
    std::mt19937 rng(hand == Handedness::right ? 21 : 22);
    KeypointFitConfig config;
    for (int trial = 0; trial < 20; ++trial) {
      const JointParams truth = plausible_params(model, rng);
      const auto target = joints_of(model, truth);
      const HandFit fit = fit_keypoints(model, all_valid(target), config);
      INFO("hand " << (hand == Handedness::right ? "right" : "left") << " trial " << trial);
      CHECK(fit.fitted);
      CHECK(fit.mean_mm < 0.5);
      CHECK(fit.max_mm < 1.0);
      const auto want = joint_bend_angles(target.data());
      const auto got = joint_bend_angles(fit.joints.data());
      for (int j = 0; j < 15; ++j) CHECK(std::fabs(want[j] - got[j]) * 180.0 / M_PI < 1.0);
      CHECK(fit.limit_excess <= 0.0);
    }
  }
}

TEST_CASE("keypoint fit: missing keypoints leave their joints at the prior, the rest still fit") {
  const JointModel model = make_joint_model(make_procedural_hand(Handedness::right));
  std::mt19937 rng(31);
  const JointParams truth = plausible_params(model, rng);
  HandKeypoints k = all_valid(joints_of(model, truth));
  k.valid[kTipJoint0 + kIndex] = 0;  // the index tip is unseen
  k.valid[kFingerJoints[kPinky][2]] = 0;
  const HandFit fit = fit_keypoints(model, k, KeypointFitConfig{});
  CHECK(std::isnan(fit.residual_mm[kTipJoint0 + kIndex]));
  CHECK(fit.mean_mm < 0.5);
  HandKeypoints too_few;
  for (int j = 0; j < 4; ++j) too_few.valid[j] = 1;
  CHECK_THROWS_WITH(fit_keypoints(model, too_few, KeypointFitConfig{}),
                    Catch::Contains("4 valid keypoints, at least 5 needed"));
}

TEST_CASE("keypoint fit: a sequence shares one shape and recovers it") {
  const JointModel model = make_joint_model(make_procedural_hand(Handedness::right));
  std::mt19937 rng(41);
  JointParams truth = plausible_params(model, rng);
  std::vector<HandKeypoints> frames;
  for (int f = 0; f < 6; ++f) {
    JointParams p = plausible_params(model, rng);
    p.shape = truth.shape;
    frames.push_back(all_valid(joints_of(model, p)));
  }
  const auto fits = fit_keypoint_sequence(model, frames, KeypointFitConfig{});
  for (const HandFit& fit : fits) {
    CHECK(fit.mean_mm < 0.5);
    for (int s = 0; s < kShapeDim; ++s) CHECK(fit.params.shape[s] == fits[0].params.shape[s]);
  }
  // Modes that move joints are recovered; finger girth and thickness (3, 4) move none.
  for (int s : {0, 1, 2, 5, 6}) CHECK(std::fabs(fits[0].params.shape[s] - truth.shape[s]) < 0.05);
}

TEST_CASE("keypoint fit: a left hand's keypoints fitted with the right rig miss or break joint limits") {
  const JointModel right = make_joint_model(make_procedural_hand(Handedness::right));
  const JointModel left = make_joint_model(make_procedural_hand(Handedness::left));
  std::mt19937 rng(51);
  int caught = 0;
  for (int trial = 0; trial < 10; ++trial) {
    const auto target = joints_of(left, plausible_params(left, rng));
    const HandFit as_left = fit_keypoints(left, all_valid(target), KeypointFitConfig{});
    const HandFit as_right = fit_keypoints(right, all_valid(target), KeypointFitConfig{});
    CHECK(as_left.mean_mm < 0.5);
    if (as_right.mean_mm > 3.0 * as_left.mean_mm + 2.0 || as_right.limit_excess > 0.1) ++caught;
  }
  CHECK(caught >= 9);
}

TEST_CASE("keypoint fit: fit.shape_limit is where the shape's soft limit starts") {
  const JointModel model = make_joint_model(make_procedural_hand(Handedness::right));
  JointParams truth;
  truth.shape[2] = 5.0;  // a palm 25 % wider than the built-in hand's, beyond the default limit
  truth.trans = {0.0, 0.0, 0.8};
  HandKeypoints k;
  joint_positions(model, truth, k.joints.data());
  k.valid.fill(1);
  KeypointFitConfig config;
  const HandFit held = fit_keypoints(model, k, config);
  config.shape_limit = 8.0;
  const HandFit free = fit_keypoints(model, k, config);
  INFO("held " << held.params.shape[2] << " (" << held.mean_mm << " mm), free " << free.params.shape[2] << " (" << free.mean_mm << " mm)");
  CHECK(free.params.shape[2] > 4.7);  // the shape prior and the other modes take a little of it
  CHECK(free.mean_mm < 0.05);
  // The default limit holds the palm short of its width, and the joints pay for it.
  CHECK(held.params.shape[2] < 3.2);
  CHECK(held.mean_mm > 2 * free.mean_mm);
}
