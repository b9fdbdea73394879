// LBS and Rodrigues: plain-loop reference, invariants (rest pose, rigid global rotation, subtree
// motion, chain composition) and finite-difference gradients in double precision.
#include <ATen/ATen.h>

#include "hand/joint_order.h"
#include "hand/lbs.h"
#include "hand/lbs_one_pose.h"
#include "hand/procedural_hand.h"
#include "rig_fixtures.h"

#include "catch_after_torch.h"  // last: after c10's glog (see there)

using namespace handscs;

namespace {

const auto f64 = torch::kFloat64;

double max_abs(const torch::Tensor& a, const torch::Tensor& b) {
  return (a.to(f64) - b.to(f64)).abs().max().item<double>();
}

torch::Tensor zeros(int64_t batch, int64_t n) { return torch::zeros({batch, n}, f64); }

const Rig& builtin() {
  static const Rig rig = make_procedural_hand(Handedness::right);
  return rig;
}

// Subtree of joint j (j and all its descendants) in the MANO tree.
std::vector<bool> subtree(int j) {
  std::vector<bool> in(kRigJoints, false);
  in[j] = true;
  for (int k = j + 1; k < kRigJoints; ++k)
    if (kManoParents[k] >= 0 && in[kManoParents[k]]) in[k] = true;
  return in;
}

}  // namespace

TEST_CASE("lbs matches a plain-loop MANO reference (toy rig with pose and shape blend shapes)") {
  const Rig rig = test::make_toy_rig(40, 7);
  torch::manual_seed(11);
  const int64_t batch = 3;
  const torch::Tensor pose = torch::randn({batch, kPoseDim}, f64) * 0.7;
  const torch::Tensor shape = torch::randn({batch, kShapeDim}, f64);
  const torch::Tensor trans = torch::randn({batch, 3}, f64) * 0.1;
  for (bool flat : {true, false}) {
    const LbsOutput out = lbs(rig, pose, shape, trans, LbsOptions{flat});
    REQUIRE(out.vertices.sizes() == at::IntArrayRef({batch, 40, 3}));
    REQUIRE(out.joints.sizes() == at::IntArrayRef({batch, 21, 3}));
    REQUIRE(out.joint_transforms.sizes() == at::IntArrayRef({batch, 16, 4, 4}));
    REQUIRE(out.vertex_transforms.sizes() == at::IntArrayRef({batch, 40, 4, 4}));
    for (int64_t b = 0; b < batch; ++b) {
      std::vector<double> p(kPoseDim), beta(kShapeDim);
      for (int i = 0; i < kPoseDim; ++i) p[i] = pose[b][i].item<double>();
      for (int i = 0; i < kShapeDim; ++i) beta[i] = shape[b][i].item<double>();
      const std::array<double, 3> t = {trans[b][0].item<double>(), trans[b][1].item<double>(),
                                       trans[b][2].item<double>()};
      const test::ReferenceLbs ref = test::reference_lbs(rig, p, beta, t, flat);
      const torch::Tensor ref_vertices = torch::tensor(ref.vertices, f64).view({40, 3});
      const torch::Tensor ref_joints = torch::tensor(ref.joints, f64).view({21, 3});
      const torch::Tensor ref_transforms = torch::tensor(ref.transforms, f64).view({16, 3, 4});
      CHECK(max_abs(out.vertices[b], ref_vertices) < 1e-12);
      CHECK(max_abs(out.joints[b], ref_joints) < 1e-12);
      CHECK(max_abs(out.joint_transforms[b].slice(1, 0, 3), ref_transforms) < 1e-12);
    }
  }
}

TEST_CASE("lbs_one_pose gives every output of lbs, in double and in float") {
  // The toy rig has pose and shape blend shapes (the procedural hand's are zero) and enough
  // vertices for several parallel chunks; the poses include a zero one (every joint on the Taylor
  // branch) and large angles.
  const Rig rig = test::make_toy_rig(300, 7);
  torch::manual_seed(12);
  const std::vector<torch::Tensor> poses = {torch::zeros({kPoseDim}, f64),
                                            torch::randn({kPoseDim}, f64) * 0.7,
                                            torch::randn({kPoseDim}, f64) * 2.0};
  const torch::Tensor shape = torch::randn({kShapeDim}, f64);
  const torch::Tensor trans = torch::randn({3}, f64) * 0.1;
  for (const auto& pose : poses)
    for (bool flat : {true, false})
      for (const auto dtype : {torch::kFloat64, torch::kFloat32}) {
        INFO("flat " << flat << ", dtype " << dtype);
        const LbsOptions options{flat};
        const LbsOutput ops = lbs(rig, pose.to(dtype).view({1, kPoseDim}),
                                  shape.to(dtype).view({1, kShapeDim}), trans.to(dtype).view({1, 3}), options);
        const LbsOutput loops = lbs_one_pose(rig, pose.to(dtype), shape.to(dtype), trans.to(dtype), options);
        // In double both are exact to rounding; in float lbs() rounds every op in float32 (values
        // are ~0.1 m and transforms ~1), lbs_one_pose only its outputs.
        const double tol = dtype == torch::kFloat64 ? 1e-12 : 2e-5;
        const std::vector<std::pair<const char*, std::pair<torch::Tensor, torch::Tensor>>> fields = {
            {"vertices", {ops.vertices, loops.vertices}},
            {"joints", {ops.joints, loops.joints}},
            {"rest_joints", {ops.rest_joints, loops.rest_joints}},
            {"joint_transforms", {ops.joint_transforms, loops.joint_transforms}},
            {"blend_offsets", {ops.blend_offsets, loops.blend_offsets}},
            {"shape_offsets", {ops.shape_offsets, loops.shape_offsets}},
            {"vertex_transforms", {ops.vertex_transforms, loops.vertex_transforms}}};
        for (const auto& [name, pair] : fields) {
          INFO(name);
          REQUIRE(pair.second.sizes() == pair.first.sizes());
          CHECK(pair.second.scalar_type() == dtype);
          CHECK(max_abs(pair.first, pair.second) < tol);
        }
      }
}

TEST_CASE("lbs_one_pose names what is wrong with its inputs") {
  const Rig rig = test::make_toy_rig(20, 3);
  const auto f64 = torch::kFloat64;
  CHECK_THROWS_WITH(lbs_one_pose(rig, torch::zeros({2, 24}, f64), torch::zeros({10}, f64), torch::zeros({3}, f64)),
                    Catch::Contains("pose must be [48] or [1, 48]"));
  CHECK_THROWS_WITH(lbs_one_pose(rig, torch::zeros({48}, f64), torch::zeros({9}, f64), torch::zeros({3}, f64)),
                    Catch::Contains("shape must be [10]"));
  Rig broken = rig;
  broken.posedirs = broken.posedirs.narrow(2, 0, 100);
  CHECK_THROWS_WITH(lbs_one_pose(broken, torch::zeros({48}, f64), torch::zeros({10}, f64), torch::zeros({3}, f64)),
                    Catch::Contains("the rig's posedirs must hold 8100 values"));
}

TEST_CASE("lbs: zero pose returns the template") {
  for (const Rig* rig_ptr : std::vector<const Rig*>{&builtin(), nullptr}) {
    const Rig rig = rig_ptr ? *rig_ptr : test::make_toy_rig(30, 3);
    const int64_t V = rig.num_vertices();
    const LbsOutput out =
        lbs(rig, zeros(2, kPoseDim), zeros(2, kShapeDim), zeros(2, 3), LbsOptions{true});
    CHECK(max_abs(out.vertices, rig.v_template.unsqueeze(0).expand({2, V, 3})) < 1e-14);
    CHECK(max_abs(out.blend_offsets, torch::zeros({2, V, 3}, f64)) == 0.0);
    CHECK(max_abs(out.joint_transforms, torch::eye(4, f64).expand({2, 16, 4, 4})) < 1e-15);
    CHECK(max_abs(out.vertex_transforms, torch::eye(4, f64).expand({2, V, 4, 4})) < 1e-14);
    const torch::Tensor regressed = torch::matmul(rig.j_regressor, rig.v_template);
    CHECK(max_abs(out.rest_joints[0].slice(0, 0, 16), regressed) < 1e-15);
    CHECK(max_abs(out.joints, out.rest_joints) < 1e-14);
    // With flat_hand_mean = false the zero pose is hands_mean; its negation gives the template.
    torch::Tensor pose = zeros(1, kPoseDim);
    pose.slice(1, 3).copy_(-rig.hands_mean.unsqueeze(0));
    const LbsOutput relative = lbs(rig, pose, zeros(1, kShapeDim), zeros(1, 3), LbsOptions{false});
    CHECK(max_abs(relative.vertices[0], rig.v_template) < 1e-14);
    const LbsOutput mean =
        lbs(rig, zeros(1, kPoseDim), zeros(1, kShapeDim), zeros(1, 3), LbsOptions{false});
    CHECK(max_abs(mean.vertices[0], rig.v_template) > 1e-3);  // hands_mean is not the flat hand
  }
}

TEST_CASE("lbs: a global rotation moves the hand rigidly about the wrist, then translates") {
  const Rig& rig = builtin();
  torch::Tensor pose = zeros(1, kPoseDim);
  pose[0][0] = 0.3;
  pose[0][1] = -0.5;
  pose[0][2] = 0.8;
  const torch::Tensor trans = torch::tensor({{0.1, -0.2, 0.5}}, f64);
  const LbsOutput out = lbs(rig, pose, zeros(1, kShapeDim), trans, LbsOptions{true});
  const double axis[3] = {0.3, -0.5, 0.8};
  const test::Mat3 r = test::reference_rotation(axis);
  torch::Tensor R = torch::empty({3, 3}, f64);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) R[i][j] = r[i][j];
  const torch::Tensor wrist = out.rest_joints[0][0];
  const torch::Tensor expected = torch::matmul(rig.v_template - wrist, R.t()) + wrist + trans;
  CHECK(max_abs(out.vertices[0], expected) < 1e-14);
  const torch::Tensor expected_joints =
      torch::matmul(out.rest_joints[0] - wrist, R.t()) + wrist + trans;
  CHECK(max_abs(out.joints[0], expected_joints) < 1e-14);
  // Distances between vertices are preserved.
  auto distances = [](const torch::Tensor& p) {  // [N, 3] -> [N, N], exact pairwise differences
    return (p.unsqueeze(0) - p.unsqueeze(1)).norm(2, -1);
  };
  const torch::Tensor d0 = distances(rig.v_template.slice(0, 0, 300));
  const torch::Tensor d1 = distances(out.vertices[0].slice(0, 0, 300));
  CHECK(max_abs(d0, d1) < 1e-14);
}

TEST_CASE("lbs: rotating one joint moves only the vertices and joints of its subtree") {
  const Rig& rig = builtin();
  const int64_t V = rig.num_vertices();
  const torch::Tensor zero_shape = zeros(1, kShapeDim), zero_trans = zeros(1, 3);
  const LbsOutput rest = lbs(rig, zeros(1, kPoseDim), zero_shape, zero_trans, LbsOptions{true});
  for (int j = 1; j < kRigJoints; ++j) {
    INFO("joint " << j);
    torch::Tensor pose = zeros(1, kPoseDim);
    const double axis[3] = {0.2, -0.3, 0.6};
    for (int c = 0; c < 3; ++c) pose[0][3 * j + c] = axis[c];
    const LbsOutput out = lbs(rig, pose, zero_shape, zero_trans, LbsOptions{true});
    const std::vector<bool> in = subtree(j);
    torch::Tensor mask = torch::zeros({kRigJoints}, f64);
    for (int k = 0; k < kRigJoints; ++k) mask[k] = in[k] ? 1.0 : 0.0;
    const torch::Tensor subtree_weight = torch::matmul(rig.weights, mask);  // [V]
    const torch::Tensor moved = (out.vertices[0] - rig.v_template).norm(2, 1);
    const torch::Tensor outside = subtree_weight == 0;
    const torch::Tensor inside = subtree_weight > 1 - 1e-12;
    REQUIRE(outside.sum().item<int64_t>() > V / 2);
    REQUIRE(inside.sum().item<int64_t>() > 10);
    CHECK(moved.masked_select(outside).max().item<double>() < 1e-15);
    // Vertices skinned only by the subtree turn rigidly about joint j.
    const test::Mat3 r = test::reference_rotation(axis);
    torch::Tensor R = torch::empty({3, 3}, f64);
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) R[a][b] = r[a][b];
    const torch::Tensor centre = rest.rest_joints[0][j];
    const torch::Tensor expected = torch::matmul(rig.v_template - centre, R.t()) + centre;
    const torch::Tensor error = (out.vertices[0] - expected).norm(2, 1).masked_select(inside);
    CHECK(error.max().item<double>() < 1e-14);
    CHECK(moved.masked_select(inside).max().item<double>() > 1e-3);
    for (int k = 0; k < kRigJoints; ++k) {
      const double joint_moved = (out.joints[0][k] - rest.joints[0][k]).norm().item<double>();
      if (!in[k] || k == j)
        CHECK(joint_moved < 1e-15);
      else
        CHECK(joint_moved > 1e-3);
    }
  }
}

TEST_CASE("lbs: joint transforms compose along the kinematic chain") {
  const Rig rig = test::make_toy_rig(25, 5);
  torch::manual_seed(2);
  const torch::Tensor pose = torch::randn({2, kPoseDim}, f64) * 0.8;
  const torch::Tensor shape = torch::randn({2, kShapeDim}, f64);
  const torch::Tensor trans = torch::randn({2, 3}, f64) * 0.2;
  const LbsOutput out = lbs(rig, pose, shape, trans, LbsOptions{true});
  for (int64_t b = 0; b < 2; ++b) {
    // G_k = A_k [I | J_k] without the translation; G_k = G_parent [R_k | J_k - J_parent].
    const torch::Tensor J = out.rest_joints[b].slice(0, 0, 16);
    std::vector<torch::Tensor> G(16);
    for (int k = 0; k < 16; ++k) {
      torch::Tensor shift = torch::eye(4, f64);
      shift.slice(0, 0, 3).select(1, 3).copy_(J[k]);
      G[k] = torch::matmul(out.joint_transforms[b][k], shift);
      G[k].slice(0, 0, 3).select(1, 3).sub_(trans[b]);
      const double* a = pose[b].data_ptr<double>() + 3 * k;
      const test::Mat3 r = test::reference_rotation(a);
      torch::Tensor local = torch::eye(4, f64);
      for (int i = 0; i < 3; ++i) {
        for (int c = 0; c < 3; ++c) local[i][c] = r[i][c];
        local[i][3] = J[k][i].item<double>() - (k ? J[kManoParents[k]][i].item<double>() : 0.0);
      }
      const torch::Tensor expected = k ? torch::matmul(G[kManoParents[k]], local) : local;
      CHECK(max_abs(G[k], expected) < 1e-14);
      CHECK(max_abs(out.joints[b][k], G[k].slice(0, 0, 3).select(1, 3) + trans[b]) < 1e-14);
    }
    // Per-vertex transforms are the weight-blended joint transforms.
    const torch::Tensor blended =
        torch::matmul(rig.weights, out.joint_transforms[b].reshape({16, 16})).view({25, 4, 4});
    CHECK(max_abs(out.vertex_transforms[b], blended) < 1e-15);
  }
}

namespace {

// Autograd gradient vs central differences of L = sum(c_v . vertices) + sum(c_j . joints).
void check_gradients(const Rig& rig, torch::Tensor pose, bool flat) {
  torch::manual_seed(21);
  const int64_t V = rig.num_vertices();
  torch::Tensor shape = torch::randn({1, kShapeDim}, f64);
  torch::Tensor trans = torch::randn({1, 3}, f64) * 0.1;
  const torch::Tensor c_v = torch::randn({1, V, 3}, f64);
  const torch::Tensor c_j = torch::randn({1, 21, 3}, f64);
  auto loss = [&](const torch::Tensor& p, const torch::Tensor& s, const torch::Tensor& t) {
    const LbsOutput out = lbs(rig, p, s, t, LbsOptions{flat});
    return (out.vertices * c_v).sum() + (out.joints * c_j).sum();
  };
  pose = pose.clone().requires_grad_(true);
  shape.requires_grad_(true);
  trans.requires_grad_(true);
  loss(pose, shape, trans).backward();
  REQUIRE(torch::isfinite(pose.grad()).all().item<bool>());
  // Central differences, step 1e-6: truncation ~1e-12 relative, rounding ~1e-10.
  const double h = 1e-6;
  torch::NoGradGuard no_grad;
  for (torch::Tensor* x : {&pose, &shape, &trans}) {
    const torch::Tensor base = x->detach().clone();
    for (int64_t i = 0; i < base.size(1); ++i) {
      torch::Tensor plus = base.clone(), minus = base.clone();
      plus[0][i] += h;
      minus[0][i] -= h;
      auto eval = [&](const torch::Tensor& value) {
        return loss(x == &pose ? value : pose.detach(), x == &shape ? value : shape.detach(),
                    x == &trans ? value : trans.detach())
            .item<double>();
      };
      const double numeric = (eval(plus) - eval(minus)) / (2 * h);
      const double analytic = x->grad()[0][i].item<double>();
      INFO("input " << (x == &pose ? "pose" : x == &shape ? "shape" : "trans") << " [" << i << "]");
      CHECK(analytic == Approx(numeric).epsilon(1e-6).margin(1e-7));
    }
  }
}

}  // namespace

TEST_CASE("lbs: gradients w.r.t. pose, shape and trans match finite differences (double)") {
  const Rig toy = test::make_toy_rig(30, 9);
  torch::manual_seed(4);
  SECTION("random pose, toy rig") {
    check_gradients(toy, torch::randn({1, kPoseDim}, f64) * 0.6, true);
  }
  SECTION("exactly zero pose, toy rig") { check_gradients(toy, zeros(1, kPoseDim), true); }
  SECTION("zero relative pose with hands_mean, toy rig") {
    check_gradients(toy, zeros(1, kPoseDim), false);
  }
  SECTION("random pose, built-in hand") {
    check_gradients(builtin(), torch::randn({1, kPoseDim}, f64) * 0.4, false);
  }
}

TEST_CASE("rodrigues: closed form, orthonormal, and finite value and gradient at zero angle") {
  torch::manual_seed(8);
  // Angles on both sides of the Taylor switch (t^2 = 1e-4 in double) and large ones.
  torch::Tensor directions = torch::randn({6, 3}, f64);
  directions = directions / directions.norm(2, 1, true);
  const torch::Tensor angles = torch::tensor({1e-9, 0.0099, 0.0101, 0.5, 2.0, 3.1}, f64);
  const torch::Tensor a = directions * angles.unsqueeze(1);
  const torch::Tensor R = rodrigues(a);
  for (int64_t i = 0; i < 6; ++i) {
    const test::Mat3 r = test::reference_rotation(a[i].data_ptr<double>());
    for (int p = 0; p < 3; ++p)
      for (int q = 0; q < 3; ++q) CHECK(R[i][p][q].item<double>() == Approx(r[p][q]).margin(1e-15));
  }
  CHECK(max_abs(torch::matmul(R, R.transpose(1, 2)), torch::eye(3, f64).expand({6, 3, 3})) < 1e-14);

  for (auto dtype : {torch::kFloat64, torch::kFloat32}) {
    torch::Tensor zero = torch::zeros({3}, dtype).requires_grad_(true);
    const torch::Tensor Rz = rodrigues(zero);
    CHECK(max_abs(Rz, torch::eye(3, f64)) == 0.0);
    // d/da sum(C . R(a)) at 0 is sum(C . [e_i]_x): the skew part of C.
    const torch::Tensor C =
        torch::tensor({{1.0, 2.0, 3.0}, {4.0, 5.0, 6.0}, {7.0, 8.0, 10.0}}, dtype);
    (Rz * C).sum().backward();
    const torch::Tensor g = zero.grad().to(f64);
    CHECK(g[0].item<double>() == Approx(8.0 - 6.0));  // C[2][1] - C[1][2]
    CHECK(g[1].item<double>() == Approx(3.0 - 7.0));  // C[0][2] - C[2][0]
    CHECK(g[2].item<double>() == Approx(4.0 - 2.0));  // C[1][0] - C[0][1]
  }
  // Gradients just below and above the Taylor switch agree with finite differences.
  for (double angle : {0.0099, 0.0101, 1.3}) {
    torch::Tensor x = (directions[0] * angle).clone().requires_grad_(true);
    const torch::Tensor C = torch::randn({3, 3}, f64);
    (rodrigues(x) * C).sum().backward();
    for (int i = 0; i < 3; ++i) {
      torch::Tensor plus = x.detach().clone(), minus = x.detach().clone();
      plus[i] += 1e-7;
      minus[i] -= 1e-7;
      const double numeric = ((rodrigues(plus) * C).sum().item<double>() -
                              (rodrigues(minus) * C).sum().item<double>()) /
                             2e-7;
      CHECK(x.grad()[i].item<double>() == Approx(numeric).epsilon(1e-6).margin(1e-8));
    }
  }
}

TEST_CASE("lbs: output dtype follows the pose (float32 agrees with float64)") {
  const Rig& rig = builtin();
  torch::manual_seed(3);
  const torch::Tensor pose = torch::randn({2, kPoseDim}, f64) * 0.5;
  const torch::Tensor shape = torch::randn({2, kShapeDim}, f64);
  const torch::Tensor trans = torch::randn({2, 3}, f64) * 0.1;
  const LbsOutput d = lbs(rig, pose, shape, trans);
  const LbsOutput f = lbs(rig, pose.to(torch::kFloat32), shape, trans);
  CHECK(f.vertices.scalar_type() == torch::kFloat32);
  CHECK(f.joints.scalar_type() == torch::kFloat32);
  CHECK(f.vertex_transforms.scalar_type() == torch::kFloat32);
  CHECK(d.vertices.scalar_type() == torch::kFloat64);
  CHECK(max_abs(d.vertices, f.vertices) < 1e-6);
  CHECK(max_abs(d.joints, f.joints) < 1e-6);
}

TEST_CASE("lbs: bad input shapes are rejected with the sizes received") {
  const Rig& rig = builtin();
  CHECK_THROWS_WITH(lbs(rig, zeros(1, 45), zeros(1, 10), zeros(1, 3)),
                    Catch::Contains("expected pose [B, 48], got [1, 45]"));
  CHECK_THROWS_WITH(lbs(rig, zeros(2, 48), zeros(1, 10), zeros(2, 3)),
                    Catch::Contains("expected shape [2, 10], got [1, 10]"));
  CHECK_THROWS_WITH(lbs(rig, zeros(2, 48), zeros(2, 10), zeros(2, 2)),
                    Catch::Contains("expected trans [2, 3], got [2, 2]"));
  CHECK_THROWS_WITH(lbs(rig, torch::zeros({1, 48}, torch::kInt64), zeros(1, 10), zeros(1, 3)),
                    Catch::Contains("float32 or float64"));
  CHECK_THROWS_WITH(rodrigues(torch::zeros({4, 2}, f64)), Catch::Contains("[..., 3], got [4, 2]"));
}

TEST_CASE("InterHand joint order: tip to base per finger (thumb..pinky), then the wrist") {
  // Derived from the finger chains: for each finger, its tip, then its joints distal to base.
  std::array<int, 21> expected{};
  int i = 0;
  for (int f : {kThumb, kIndex, kMiddle, kRing, kPinky}) {
    expected[i++] = kTipJoint0 + f;
    for (int k = 2; k >= 0; --k) expected[i++] = kFingerJoints[f][k];
  }
  expected[i] = 0;
  CHECK(expected == kInterHandFromMano21);
  CHECK(std::string(kMano21Names[kInterHandFromMano21[4]]) == "index_tip");
  CHECK(std::string(kMano21Names[kInterHandFromMano21[19]]) == "pinky1");
}
