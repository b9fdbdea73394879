// The built-in procedural hand: closed, outward, non-degenerate, self-intersection-free skin;
// joints inside; weights and regressor valid; proportions, regions, shape modes; left = mirror.
#include <ATen/ATen.h>

#include "hand/joint_order.h"
#include "hand/lbs.h"
#include "hand/procedural_hand.h"
#include "hand/rig_validate.h"
#include "mesh_checks.h"

#include "catch_after_torch.h"  // last: after c10's glog (see there)

using namespace handscs;

namespace {


const Rig& right_hand() {
  static const Rig rig = make_procedural_hand(Handedness::right);
  return rig;
}

LbsOutput rest_of(const Rig& rig, const torch::Tensor& shape) {
  return lbs(rig, torch::zeros({1, kPoseDim}, torch::kFloat64), shape, torch::zeros({1, 3}, torch::kFloat64),
             LbsOptions{true});
}

torch::Tensor no_shape() { return torch::zeros({1, kShapeDim}, torch::kFloat64); }

}  // namespace

TEST_CASE("procedural hand: size, topology counts and proportions of an adult hand") {
  const Rig& rig = right_hand();
  validate_rig(rig, "builtin");
  const int64_t V = rig.num_vertices(), F = rig.faces.size(0);
  CHECK(V >= 800);
  CHECK(V <= 2000);
  CHECK(F == 2 * V - 4);  // closed genus-0 triangle mesh: Euler characteristic 2
  const torch::Tensor joints = rest_of(rig, no_shape()).rest_joints[0];
  const double length = (joints[18] - joints[0]).norm().item<double>();  // wrist -> middle tip
  CHECK(length > 0.18);
  CHECK(length < 0.19);
  // MANO's canonical frame: fingers along -x from the wrist, thumb on the +z side.
  CHECK(joints[18][0].item<double>() < joints[0][0].item<double>() - 0.15);
  CHECK(joints[16][2].item<double>() > joints[17][2].item<double>());
  CHECK(joints[17][2].item<double>() > joints[18][2].item<double>());
  CHECK(joints[18][2].item<double>() > joints[19][2].item<double>());
  CHECK(joints[19][2].item<double>() > joints[20][2].item<double>());
  // Palm width at the knuckles (index to pinky MCP) between 5 and 6.5 cm.
  const double knuckles = (joints[1] - joints[7]).norm().item<double>();
  CHECK(knuckles > 0.050);
  CHECK(knuckles < 0.065);
  // Phalanges shrink from proximal to distal on every finger.
  for (int f = 0; f < kFingers; ++f) {
    const auto& c = kFingerJoints[f];
    const double l1 = (joints[c[1]] - joints[c[0]]).norm().item<double>();
    const double l2 = (joints[c[2]] - joints[c[1]]).norm().item<double>();
    const double l3 = (joints[kTipJoint0 + f] - joints[c[2]]).norm().item<double>();
    CHECK(l1 > l2);
    CHECK(l2 > 0.5 * l3);
  }
}

TEST_CASE("procedural hand: closed, consistently oriented outwards, no degenerate faces") {
  const Rig& rig = right_hand();
  const test::MeshData m = test::mesh_data(rig.v_template, rig.faces);
  const test::EdgeReport edges = test::edge_report(m);
  CHECK(edges.not_two_faces == 0);
  CHECK(edges.inconsistent == 0);
  CHECK(static_cast<int64_t>(m.v.size()) - edges.edges + static_cast<int64_t>(m.f.size()) == 2);
  CHECK(test::signed_volume(m) > 0);
  // Volume of a hand: roughly 300-500 cm^3.
  CHECK(test::signed_volume(m) > 250e-6);
  CHECK(test::signed_volume(m) < 550e-6);
  double smallest_area = 1e9, smallest_angle = 10;
  for (size_t i = 0; i < m.f.size(); ++i) {
    smallest_area = std::min(smallest_area, test::triangle_area(m, i));
    smallest_angle = std::min(smallest_angle, test::min_angle(m, i));
  }
  CHECK(smallest_area > 1e-8);  // 0.01 mm^2
  CHECK(smallest_angle > 2.0 * M_PI / 180.0);
  // Every vertex is used by some face.
  std::vector<int> used(m.v.size(), 0);
  for (const auto& f : m.f)
    for (int64_t id : f) used[id] = 1;
  CHECK(std::count(used.begin(), used.end(), 0) == 0);
}

TEST_CASE("procedural hand: no self-intersections at rest, relaxed, and with shape modes") {
  const Rig& rig = right_hand();
  CHECK(test::self_intersections(test::mesh_data(rig.v_template, rig.faces)) == 0);
  // The relaxed pose (hands_mean) and each shape mode at +-2.
  const LbsOutput relaxed = lbs(rig, torch::zeros({1, kPoseDim}, torch::kFloat64), no_shape(),
                                torch::zeros({1, 3}, torch::kFloat64), LbsOptions{false});
  CHECK(test::self_intersections(test::mesh_data(relaxed.vertices[0], rig.faces)) == 0);
  for (int mode = 0; mode < 7; ++mode)
    for (double value : {-2.0, 2.0}) {
      torch::Tensor shape = no_shape();
      shape[0][mode] = value;
      const LbsOutput out = rest_of(rig, shape);
      INFO("shape mode " << mode << " = " << value);
      CHECK(test::self_intersections(test::mesh_data(out.vertices[0], rig.faces)) == 0);
    }
}

TEST_CASE("procedural hand: all 16 joints lie inside the skin (winding number 1)") {
  const Rig& rig = right_hand();
  const test::MeshData m = test::mesh_data(rig.v_template, rig.faces);
  const torch::Tensor joints = rest_of(rig, no_shape()).rest_joints[0];
  for (int k = 0; k < kRigJoints; ++k) {
    INFO("joint " << k << " " << kMano21Names[k]);
    const test::P3 q = {joints[k][0].item<double>(), joints[k][1].item<double>(),
                        joints[k][2].item<double>()};
    CHECK(test::winding_number(m, q) == Approx(1.0).margin(1e-9));
  }
  CHECK(test::winding_number(m, {0.0, 0.2, 0.0}) == Approx(0.0).margin(1e-9));
  // Between the index and middle fingertips: outside.
  const torch::Tensor between = 0.5 * (joints[17] + joints[18]);
  CHECK(test::winding_number(m, {between[0].item<double>(), between[1].item<double>(),
                                 between[2].item<double>()}) == Approx(0.0).margin(1e-9));
}

TEST_CASE("procedural hand: weights on the simplex, smooth across edges, local to each finger") {
  const Rig& rig = right_hand();
  const torch::Tensor w = rig.weights;
  CHECK(w.min().item<double>() >= 0.0);
  CHECK((w.sum(1) - 1).abs().max().item<double>() < 1e-12);
  // Smooth: across any edge, no joint's weight jumps by more than 0.55 (the knuckle webs, where
  // neighbouring fingers meet, are the largest steps: half a finger on each side).
  const torch::Tensor f = rig.faces;
  double largest_step = 0;
  for (int e = 0; e < 3; ++e) {
    const torch::Tensor a = w.index_select(0, f.select(1, e));
    const torch::Tensor b = w.index_select(0, f.select(1, (e + 1) % 3));
    largest_step = std::max(largest_step, (a - b).abs().max().item<double>());
  }
  CHECK(largest_step < 0.55);
  // Each joint drives some vertices fully, and a finger's joints never reach another finger.
  for (int k = 0; k < kRigJoints; ++k) CHECK(w.select(1, k).max().item<double>() > 0.9);
  for (int f1 = 0; f1 < kFingers; ++f1)
    for (int f2 = 0; f2 < kFingers; ++f2) {
      if (f1 == f2) continue;
      const torch::Tensor distal1 =
          w.select(1, kFingerJoints[f1][1]) + w.select(1, kFingerJoints[f1][2]);
      const torch::Tensor any2 = w.select(1, kFingerJoints[f2][0]) +
                                 w.select(1, kFingerJoints[f2][1]) +
                                 w.select(1, kFingerJoints[f2][2]);
      CHECK((distal1 * any2).max().item<double>() == 0.0);
    }
  // The joint regressor's rows are convex combinations that reproduce joints inside each ring.
  const torch::Tensor r = rig.j_regressor;
  CHECK(r.min().item<double>() >= 0.0);
  CHECK((r.sum(1) - 1).abs().max().item<double>() < 1e-12);
}

TEST_CASE("procedural hand: tips, nails and regions") {
  const Rig& rig = right_hand();
  REQUIRE(rig.vertex_labels.defined());
  const torch::Tensor labels = rig.vertex_labels;
  const torch::Tensor joints = rest_of(rig, no_shape()).rest_joints[0];
  const torch::Tensor v = rig.v_template;
  for (int f = 0; f < kFingers; ++f) {
    INFO("finger " << f);
    // The tip vertex is the farthest point along the distal phalanx.
    const torch::Tensor distal = joints[kFingerJoints[f][2]];
    const torch::Tensor tip = v[rig.tip_vertices[f]];
    const torch::Tensor direction = (tip - distal) / (tip - distal).norm();
    const torch::Tensor on_finger = rig.weights.select(1, kFingerJoints[f][2]) > 0.5;
    const torch::Tensor reach = torch::matmul(v - distal, direction).masked_select(on_finger);
    CHECK(reach.max().item<double>() == Approx(torch::dot(tip - distal, direction).item<double>()));
    // A nail: at least 8 vertices near the tip on the dorsal side of the distal phalanx.
    const torch::Tensor near_tip = (v - tip).norm(2, 1) < 0.02;
    const torch::Tensor nail = (labels == 1).logical_and(near_tip).logical_and(on_finger);
    CHECK(nail.sum().item<int64_t>() >= 8);
  }
  // Labels: 0 skin, 1 nail, 2 palmar skin, 3 forearm cut; each region present.
  for (int64_t label = 0; label < 4; ++label) CHECK((labels == label).sum().item<int64_t>() > 20);
  CHECK(labels.max().item<int64_t>() == 3);
  // Nails lie on the back of the hand (+y for the fingers) and palmar skin on the front.
  const torch::Tensor fingers_nails = (labels == 1).logical_and(v.select(1, 0) < -0.02);
  const torch::Tensor finger_axis_y =
      torch::matmul(rig.weights, joints.slice(0, 0, 16).select(1, 1));
  CHECK((v.select(1, 1) - finger_axis_y).masked_select(fingers_nails).min().item<double>() > 0);
}

TEST_CASE("procedural hand: shape modes change length, width and thickness as documented") {
  const Rig& rig = right_hand();
  const LbsOutput base = rest_of(rig, no_shape());
  auto with = [&](int mode, double value) {
    torch::Tensor shape = no_shape();
    shape[0][mode] = value;
    return rest_of(rig, shape);
  };
  auto extent = [](const torch::Tensor& v, int axis) {
    return (v.select(1, axis).max() - v.select(1, axis).min()).item<double>();
  };
  const torch::Tensor J = base.rest_joints[0];
  // 1: finger length +6 % per unit (MCP -> tip of the middle finger).
  {
    const torch::Tensor j = with(1, 1.0).rest_joints[0];
    const double l0 = (J[18] - J[4]).norm().item<double>(),
                 l1 = (j[18] - j[4]).norm().item<double>();
    CHECK(l1 / l0 == Approx(1.06).epsilon(0.01));
  }
  // 2: palm width +5 % per unit (index to pinky knuckle).
  {
    const torch::Tensor j = with(2, 1.0).rest_joints[0];
    const double w0 = (J[1] - J[7]).norm().item<double>(), w1 = (j[1] - j[7]).norm().item<double>();
    CHECK(w1 / w0 > 1.03);
    CHECK(w1 / w0 < 1.07);
  }
  // 3: thickness +6 % per unit (dorsal-palmar extent of the middle finger's proximal phalanx).
  {
    const torch::Tensor proximal = rig.weights.select(1, 4) > 0.999;
    const torch::Tensor thick = with(3, 1.0).vertices[0].select(1, 1).masked_select(proximal);
    const torch::Tensor thin = base.vertices[0].select(1, 1).masked_select(proximal);
    const double ratio =
        (thick.max() - thick.min()).item<double>() / (thin.max() - thin.min()).item<double>();
    CHECK(ratio > 1.04);
    CHECK(ratio < 1.06 + 1e-9);
  }
  // 0: overall size +4 % per unit.
  CHECK(extent(with(0, 1.0).vertices[0], 0) / extent(base.vertices[0], 0) ==
        Approx(1.04).epsilon(1e-6));
  // 6: thumb length, leaves the other fingers alone.
  {
    const torch::Tensor j = with(6, 1.0).rest_joints[0];
    CHECK((j[16] - j[13]).norm().item<double>() > 1.03 * (J[16] - J[13]).norm().item<double>());
    CHECK((j[17] - J[17]).norm().item<double>() == 0.0);
  }
  // 7-9 are unused.
  CHECK(rig.shapedirs.slice(2, 7).abs().max().item<double>() == 0.0);
}

TEST_CASE("procedural hand: deterministic, and the left hand is the mirror image of the right") {
  const Rig& right = right_hand();
  const Rig again = make_procedural_hand(Handedness::right);
  CHECK(torch::equal(right.v_template, again.v_template));
  CHECK(torch::equal(right.faces, again.faces));
  CHECK(torch::equal(right.weights, again.weights));

  const Rig left = make_procedural_hand(Handedness::left);
  CHECK(left.handedness == Handedness::left);
  validate_rig(left, "builtin:left");
  const torch::Tensor mirror = torch::tensor({-1.0, 1.0, 1.0}, torch::kFloat64);
  CHECK(torch::equal(left.v_template, right.v_template * mirror));
  const test::MeshData m = test::mesh_data(left.v_template, left.faces);
  CHECK(test::signed_volume(m) > 0);  // faces re-wound: still outward
  CHECK(test::edge_report(m).inconsistent == 0);
  // LBS of the left hand with the mirrored pose (a, -b, -c) and shape is the mirrored right LBS.
  torch::manual_seed(5);
  const torch::Tensor pose = torch::randn({2, kPoseDim}, torch::kFloat64) * 0.5;
  const torch::Tensor shape = torch::randn({2, kShapeDim}, torch::kFloat64);
  const torch::Tensor trans = torch::randn({2, 3}, torch::kFloat64) * 0.1;
  const torch::Tensor axis_sign = torch::tensor({1.0, -1.0, -1.0}, torch::kFloat64).repeat({16});
  for (bool flat : {true, false}) {
    const LbsOutput r = lbs(right, pose, shape, trans, LbsOptions{flat});
    const LbsOutput l = lbs(left, pose * axis_sign, shape, trans * mirror, LbsOptions{flat});
    CHECK((l.vertices - r.vertices * mirror).abs().max().item<double>() < 1e-14);
    CHECK((l.joints - r.joints * mirror).abs().max().item<double>() < 1e-14);
  }
}
