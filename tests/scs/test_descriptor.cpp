// Structural descriptor (paper §3.1.2): definition against a per-element reference, rigid invariance,
// continuity, guards at joints and zero-length bones, and the touching-fingers claim on a posed hand.
#include "catch_torch.h"

#include <algorithm>
#include <cmath>

#include <torch/csrc/autograd/autograd.h>
#include <torch/types.h>

#include "core/simd_level.h"
#include "hand/lbs.h"
#include "scs/descriptor.h"
#include "scs/topology.h"
#include "scs/virtual_bones.h"
#include "tensor_bits.h"

namespace {

torch::Tensor random_rotation(torch::Generator& gen) {
  auto q = at::normal(0.0, 1.0, {4}, gen, torch::kFloat64);
  q = q / q.norm();
  const double w = q[0].item<double>(), x = q[1].item<double>(), y = q[2].item<double>(),
               z = q[3].item<double>();
  return torch::tensor({1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y),
                        2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
                        2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)},
                       torch::kFloat64)
      .view({3, 3});
}

}  // namespace

TEST_CASE("descriptor: static and virtual terms match their per-element definition") {
  torch::manual_seed(3);
  const auto topology = handscs::make_static_topology(handscs::ScsConfig{});
  const auto joints = torch::randn({21, 3}, torch::kFloat64) * 0.05;
  const auto x = torch::randn({7, 3}, torch::kFloat64) * 0.05;
  const double tau = 0.08;
  const auto p = handscs::static_descriptor(x, joints, topology, tau, 1e-8);
  REQUIRE(p.sizes() == torch::IntArrayRef({7, 20}));
  for (int64_t i = 0; i < 7; ++i)
    for (int64_t e = 0; e < 20; ++e) {
      const auto ju = joints[topology.edges[e][0]];
      const auto jv = joints[topology.edges[e][1]];
      const auto r = ju - x[i];
      const auto b = jv - ju;
      const double rho = (r.dot(b) / (r.norm() * b.norm())).item<double>();
      const double d = std::exp(-r.pow(2).sum().item<double>() / (tau * tau));
      CHECK(p[i][e].item<double>() == Approx(d * rho).epsilon(1e-12));
    }
  const auto start = torch::randn({5, 3}, torch::kFloat64) * 0.05;
  const auto end = torch::randn({5, 3}, torch::kFloat64) * 0.05;
  const auto pv = handscs::virtual_descriptor(x, start, end, 1e-8);
  for (int64_t i = 0; i < 7; ++i)
    for (int64_t m = 0; m < 5; ++m) {
      const auto r = start[m] - x[i];
      const auto b = end[m] - start[m];
      const double rho = (r.dot(b) / (r.norm() * b.norm())).item<double>();
      CHECK(pv[i][m].item<double>() == Approx(r.norm().item<double>() * rho).epsilon(1e-12));
    }
}

TEST_CASE("descriptor: static part is invariant to a global rigid motion") {
  auto gen = at::detail::createCPUGenerator(11);
  const auto topology = handscs::make_static_topology(handscs::ScsConfig{});
  const auto joints = at::normal(0.0, 0.05, {21, 3}, gen, torch::kFloat64);
  const auto x = at::normal(0.0, 0.05, {50, 3}, gen, torch::kFloat64);
  const auto rot = random_rotation(gen);
  const auto shift = torch::tensor({0.3, -0.2, 1.1}, torch::kFloat64);
  const auto p0 = handscs::static_descriptor(x, joints, topology, 0.08, 1e-8);
  const auto p1 = handscs::static_descriptor(x.matmul(rot.t()) + shift, joints.matmul(rot.t()) + shift,
                                             topology, 0.08, 1e-8);
  CHECK((p0 - p1).abs().max().item<double>() < 1e-12);
}

TEST_CASE("descriptor: continuous in position") {
  auto gen = at::detail::createCPUGenerator(5);
  const auto topology = handscs::make_static_topology(handscs::ScsConfig{});
  const auto joints = at::normal(0.0, 0.05, {21, 3}, gen, torch::kFloat64);
  const auto x = at::normal(0.0, 0.05, {200, 3}, gen, torch::kFloat64);
  const auto start = at::normal(0.0, 0.05, {16, 3}, gen, torch::kFloat64);
  const auto end = at::normal(0.0, 0.05, {16, 3}, gen, torch::kFloat64);
  // Shrinking steps shrink the change linearly (no jumps): ratio of changes ~ ratio of steps.
  const auto dir = at::normal(0.0, 1.0, {200, 3}, gen, torch::kFloat64);
  auto change = [&](double h) {
    const auto a = torch::cat({handscs::static_descriptor(x, joints, topology, 0.08, 1e-8),
                               handscs::virtual_descriptor(x, start, end, 1e-8)}, 1);
    const auto b = torch::cat({handscs::static_descriptor(x + h * dir, joints, topology, 0.08, 1e-8),
                               handscs::virtual_descriptor(x + h * dir, start, end, 1e-8)}, 1);
    return (a - b).abs().max().item<double>();
  };
  const double c1 = change(1e-4), c2 = change(1e-5), c3 = change(1e-6);
  CHECK(c1 > 0);
  CHECK(c2 / c1 == Approx(0.1).margin(0.02));
  CHECK(c3 / c2 == Approx(0.1).margin(0.02));
}

TEST_CASE("descriptor: the one-pass static descriptor equals the LibTorch form") {
  torch::manual_seed(5);
  const auto topology = handscs::make_static_topology(handscs::ScsConfig{});
  for (const auto dtype : {torch::kFloat64, torch::kFloat32}) {
    auto joints = torch::randn({21, 3}, dtype) * 0.05;
    joints[2] = joints[1].clone();  // a zero-length bone
    // Random centres, some exactly on joints (the floored norms), 1,000 rows so the loop's
    // parallel chunks are exercised.
    auto x = torch::randn({1000, 3}, dtype) * 0.05;
    x.slice(0, 0, 21).copy_(joints);
    const auto ops = handscs::static_descriptor(x, joints, topology, 0.08, 1e-8);
    const auto loop = handscs::static_descriptor_loop(x, joints, topology, 0.08, 1e-8);
    REQUIRE(loop.sizes() == ops.sizes());
    REQUIRE(loop.scalar_type() == dtype);
    // Same operations in the same order; LibTorch's vectorised exp may differ by an ulp.
    const double tol = dtype == torch::kFloat64 ? 1e-14 : 2e-7;
    CHECK((loop - ops).abs().max().item<double>() <= tol);
    CHECK(torch::isfinite(loop).all().item<bool>());
  }
}

TEST_CASE("descriptor: the one-pass form refuses joints its bones do not have") {
  const auto topology = handscs::make_static_topology(handscs::ScsConfig{});
  // 16 rig joints instead of MANO21's 21: the tip bones would read past them.
  CHECK_THROWS_WITH(handscs::static_descriptor_loop(torch::zeros({4, 3}), torch::zeros({16, 3}), topology, 0.08, 1e-8),
                    Catch::Contains("uses joint 16, but only 16 joints were given"));
}

TEST_CASE("descriptor: Gaussians on joints and zero-length bones stay finite") {
  const auto topology = handscs::make_static_topology(handscs::ScsConfig{});
  auto joints = torch::randn({21, 3}, torch::kFloat64) * 0.05;
  joints[2] = joints[1].clone();  // zero-length bone (1, 2)
  // Every Gaussian sits exactly on a joint.
  auto x = joints.clone().requires_grad_(true);
  auto j = joints.clone().requires_grad_(true);
  auto p = handscs::static_descriptor(x, j, topology, 0.08, 1e-8);
  const auto start = joints.slice(0, 0, 4).clone().requires_grad_(true);
  const auto end = start.detach().clone().requires_grad_(true);  // zero-length virtual bones
  auto pv = handscs::virtual_descriptor(x, start, end, 1e-8);
  CHECK(torch::isfinite(p).all().item<bool>());
  CHECK(torch::isfinite(pv).all().item<bool>());
  (p.sum() + pv.sum()).backward();
  CHECK(torch::isfinite(x.grad()).all().item<bool>());
  CHECK(torch::isfinite(j.grad()).all().item<bool>());
  CHECK(torch::isfinite(start.grad()).all().item<bool>());
  CHECK(torch::isfinite(end.grad()).all().item<bool>());
}

TEST_CASE("descriptor: touching fingers of different bones get distinct coordinates") {
  // Built-in hand with index and middle fingers curled and pressed together: take the closest pair
  // of vertices with one on each finger. Their descriptor distance must be far larger than that of
  // a pair on one finger at least as far apart in space.
  const auto rig = handscs::load_rig_source("builtin");
  auto pose = torch::zeros({1, 48}, torch::kFloat64);
  const auto lbs0 = handscs::lbs(rig, pose, torch::zeros({1, 10}, torch::kFloat64),
                                 torch::zeros({1, 3}, torch::kFloat64), {true});
  // Rotate the index (joint 1) and middle (joint 4) MCPs towards each other about the palm normal,
  // estimated as the normal of the palm plane (wrist, index MCP, pinky MCP).
  const auto j = lbs0.joints[0];
  auto normal = torch::cross(j[1] - j[0], j[7] - j[0], 0);
  normal = normal / normal.norm();
  const auto spread_axis = normal;
  // Find the sign that closes the gap: try both and keep the one that brings the tips closer.
  double best_gap = 1e9;
  torch::Tensor best_pose;
  for (double sign : {-1.0, 1.0}) {
    auto p = torch::zeros({1, 48}, torch::kFloat64);
    p[0].slice(0, 3, 6) = sign * 0.18 * spread_axis;    // index MCP
    p[0].slice(0, 12, 15) = -sign * 0.08 * spread_axis; // middle MCP
    const auto out = handscs::lbs(rig, p, torch::zeros({1, 10}, torch::kFloat64),
                                  torch::zeros({1, 3}, torch::kFloat64), {true});
    const double gap = (out.joints[0][17] - out.joints[0][18]).norm().item<double>();
    if (gap < best_gap) {
      best_gap = gap;
      best_pose = p;
    }
  }
  const auto out = handscs::lbs(rig, best_pose, torch::zeros({1, 10}, torch::kFloat64),
                                torch::zeros({1, 3}, torch::kFloat64), {true});
  const auto verts = out.vertices[0];
  const auto owner = rig.weights.argmax(1);  // dominant joint per vertex
  auto on_finger = [&](int64_t v, std::initializer_list<int64_t> joints) {
    const int64_t o = owner[v].item<int64_t>();
    for (auto jj : joints)
      if (o == jj) return true;
    return false;
  };
  std::vector<int64_t> index_ids, middle_ids;
  for (int64_t v = 0; v < verts.size(0); ++v) {
    if (on_finger(v, {2, 3})) index_ids.push_back(v);   // index middle/distal segments
    if (on_finger(v, {5, 6})) middle_ids.push_back(v);  // middle middle/distal segments
  }
  REQUIRE(index_ids.size() > 10);
  REQUIRE(middle_ids.size() > 10);
  const auto a = verts.index_select(0, torch::tensor(index_ids));
  const auto b = verts.index_select(0, torch::tensor(middle_ids));
  const auto dist = torch::cdist(a, b);
  const int64_t flat = dist.argmin().item<int64_t>();
  const int64_t ia = flat / dist.size(1), ib = flat % dist.size(1);
  const double contact = dist[ia][ib].item<double>();
  INFO("closest index-middle vertex distance " << contact << " m");
  CHECK(contact < 0.006);  // the fingers touch (within a few mm)

  // Full descriptor as the avatar computes it: static bones on posed positions, virtual bones (from a
  // freshly initialised generator) on canonical positions, where the two fingers are far apart.
  const handscs::ScsConfig scs;
  const auto topology = handscs::make_static_topology(scs);
  torch::manual_seed(0);
  handscs::VirtualBoneGenerator generator(scs, topology);
  generator->to(torch::kFloat64);
  const auto canonical = lbs0.vertices[0];
  const auto bones = generator->forward(best_pose[0], lbs0.rest_joints[0], lbs0.rest_joints[0]);
  const auto p = torch::cat({handscs::static_descriptor(verts, out.joints[0], topology, scs.tau, 1e-8),
                             handscs::virtual_descriptor(canonical, bones.start, bones.end, 1e-8)},
                            1).detach();
  const int64_t va = index_ids[ia], vb = middle_ids[ib];
  const double cross_finger = (p[va] - p[vb]).norm().item<double>();
  // Same-finger reference: every pair of index-finger vertices at most 2 mm apart. Their descriptor
  // distances per millimetre bound how much P changes along one finger's surface.
  std::vector<double> same_finger_per_mm;
  const auto pa = p.index_select(0, torch::tensor(index_ids));
  const auto d_same = torch::cdist(a, a);
  const auto p_same = torch::cdist(pa, pa);
  for (int64_t i = 0; i < a.size(0); ++i)
    for (int64_t k = i + 1; k < a.size(0); ++k) {
      const double d = d_same[i][k].item<double>();
      if (d > 0 && d <= 0.002) same_finger_per_mm.push_back(p_same[i][k].item<double>() / (d * 1000));
    }
  REQUIRE(same_finger_per_mm.size() > 20);
  std::sort(same_finger_per_mm.begin(), same_finger_per_mm.end());
  const double p95 = same_finger_per_mm[same_finger_per_mm.size() * 95 / 100];
  const double median = same_finger_per_mm[same_finger_per_mm.size() / 2];
  const double cross_per_mm = cross_finger / (contact * 1000);
  INFO("P distance across fingers " << cross_finger << " (" << cross_per_mm
       << " per mm); along one finger: median " << median << ", 95th percentile " << p95 << " per mm");
  // Touching Gaussians of different fingers differ more per millimetre than 95% of the pairs of
  // neighbours on one finger (measured: 0.088 vs 0.044 per mm, median 0.032), with a 1.5x margin.
  CHECK(cross_per_mm > 1.5 * p95);
  CHECK(cross_per_mm > 2.5 * median);
}

TEST_CASE("descriptor: the one-pass static descriptor's gradients equal the LibTorch form's") {
  torch::manual_seed(6);
  const auto topology = handscs::make_static_topology(handscs::ScsConfig{});
  for (const auto dtype : {torch::kFloat64, torch::kFloat32}) {
    const bool is_double = dtype == torch::kFloat64;
    INFO((is_double ? "double" : "float"));
    auto joints_data = torch::randn({21, 3}, dtype) * 0.05;
    joints_data[2] = joints_data[1].clone();  // a zero-length bone: |b| on the floor
    // 0 < |b| < eps (in double; float cannot hold the offset): the floor with b != 0.
    if (is_double) joints_data[6] = joints_data[5] + 3e-9;
    auto x_data = torch::randn({700, 3}, dtype) * 0.05;
    x_data.slice(0, 0, 21).copy_(joints_data);  // |r| = 0, on the floor, for some bones
    // 0 < |r| < eps: on the floor with r != 0, where the norm's gradient must be cut.
    x_data.slice(0, 21, 42).copy_(joints_data + 3e-9);
    const auto x = x_data.clone().requires_grad_(true), joints = joints_data.clone().requires_grad_(true);
    const auto x_ref = x_data.clone().requires_grad_(true), joints_ref = joints_data.clone().requires_grad_(true);
    const auto loop = handscs::static_descriptor_loop(x, joints, topology, 0.08, 1e-8);
    const auto ops = handscs::static_descriptor(x_ref, joints_ref, topology, 0.08, 1e-8);
    REQUIRE(loop.requires_grad());
    const auto cotangent = torch::randn_like(ops);
    const auto g = torch::autograd::grad({(loop * cotangent).sum()}, {x, joints});
    const auto g_ref = torch::autograd::grad({(ops * cotangent).sum()}, {x_ref, joints_ref});
    for (int k = 0; k < 2; ++k) {
      INFO((k == 0 ? "x" : "joints"));
      // Row by row against each row's own scale: rows on the floor carry gradients ~1 / eps.
      const auto diff = (g[k] - g_ref[k]).abs().amax(1);
      const auto scale = g_ref[k].abs().amax(1);
      CHECK((diff <= (is_double ? 1e-10 : 1e-4) * (scale + 1e-6)).all().item<bool>());
      CHECK(scale.max().item<double>() > 0);
    }
  }
}

TEST_CASE("descriptor: the one-pass static descriptor's AVX-512 pass gives the plain loop's bits") {
  if (handscs::detected_simd_level() != handscs::SimdLevel::avx512) {
    WARN("no AVX-512 here: the 16-lane pass is not checked");
    return;
  }
  torch::manual_seed(7);
  const auto topology = handscs::make_static_topology(handscs::ScsConfig{});
  using handscs_test::same_bits;
  // 700 rows: the backward's three tasks of 256, 256 and 188 rows (the last with a tail of 12) and
  // the forward's split between the threads; 9 rows: a tail only; 40 rows with a NaN centre (which
  // makes the joints' sums NaN).
  for (const auto& [n, with_nan] : {std::pair<int64_t, bool>{700, false}, {9, false}, {40, true}}) {
    INFO("n = " << n);
    auto joints = torch::randn({21, 3}) * 0.05;
    joints[2] = joints[1].clone();  // a zero-length bone
    auto x = torch::randn({n, 3}) * 0.05;
    x.slice(0, 0, 5).copy_(joints.slice(0, 0, 5));  // |r| = 0 for some bones
    if (with_nan) x[6][1] = std::nan("");
    torch::Tensor value[2], grad_x[2], grad_joints[2];
    const auto cotangent = torch::randn({n, topology.size()});
    for (const auto level : {handscs::SimdLevel::generic, handscs::SimdLevel::avx512}) {
      handscs::set_simd_level(level);
      const int k = level == handscs::SimdLevel::avx512;
      const auto xl = x.clone().requires_grad_(true), jl = joints.clone().requires_grad_(true);
      value[k] = handscs::static_descriptor_loop(xl, jl, topology, 0.08, 1e-8);
      const auto g = torch::autograd::grad({(value[k] * cotangent).sum()}, {xl, jl});
      grad_x[k] = g[0];
      grad_joints[k] = g[1];
      // Without the joints' gradient (the usual fixed pose): the same x gradient.
      const auto xf = x.clone().requires_grad_(true);
      const auto gf = torch::autograd::grad(
          {(handscs::static_descriptor_loop(xf, joints, topology, 0.08, 1e-8) * cotangent).sum()}, {xf});
      CHECK(same_bits(gf[0], grad_x[k]));
    }
    handscs::set_simd_level(handscs::detected_simd_level());
    CHECK(same_bits(value[0], value[1]));
    CHECK(same_bits(grad_x[0], grad_x[1]));
    CHECK(same_bits(grad_joints[0], grad_joints[1]));
    // The comparisons cover finite values, and the NaN row where there is one.
    CHECK(torch::isfinite(grad_joints[0]).all().item<bool>() == !with_nan);
    if (with_nan) CHECK_FALSE(torch::isfinite(value[0][6]).all().item<bool>());
  }
}

TEST_CASE("descriptor: the one-pass static descriptor against central finite differences") {
  torch::manual_seed(8);
  const auto topology = handscs::make_static_topology(handscs::ScsConfig{});
  const auto joints = (torch::randn({21, 3}, torch::kFloat64) * 0.05).requires_grad_(true);
  const auto x = (torch::randn({5, 3}, torch::kFloat64) * 0.05).requires_grad_(true);
  const auto cotangent = torch::randn({5, topology.size()}, torch::kFloat64);
  const auto value = [&] {
    return (handscs::static_descriptor_loop(x, joints, topology, 0.08, 1e-8) * cotangent).sum();
  };
  const auto g = torch::autograd::grad({value()}, {x, joints});
  const double h = 1e-6;
  for (int k = 0; k < 2; ++k) {
    const auto flat = (k == 0 ? x : joints).detach().view({-1});
    for (int64_t i = 0; i < flat.numel(); i += (k == 0 ? 1 : 4)) {
      const double saved = flat[i].item<double>();
      double side[2];
      for (int s = 0; s < 2; ++s) {
        flat[i] = saved + (s == 0 ? h : -h);
        torch::NoGradGuard no_grad;
        side[s] = value().item<double>();
      }
      flat[i] = saved;
      INFO((k == 0 ? "x " : "joints ") << i);
      CHECK(g[k].view({-1})[i].item<double>() == Approx((side[0] - side[1]) / (2 * h)).epsilon(1e-5).margin(1e-7));
    }
  }
}
