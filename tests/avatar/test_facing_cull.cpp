// Back-facing Gaussians (avatar/facing_cull.h): rest normals of a mesh whose normals are known, the
// facing test against a brute-force tensor reference, and Avatar::pose with a cull against the
// exact pose whose culled Gaussians are made transparent by hand (same image, same gradients for
// every parameter; at inference the same kept Gaussians).
#include "catch_torch.h"

#include <cmath>
#include <tuple>

#include <torch/types.h>

#include "avatar/avatar.h"
#include "avatar/facing_cull.h"
#include "core/error.h"
#include "small_avatar.h"

namespace {

// The smallest cosine over the cameras of (L n, x - c) by the definition, with tensor ops; -inf
// for a zero-length normal or ray (kept at any threshold).
torch::Tensor smallest_cosine_reference(const torch::Tensor& linear, const torch::Tensor& normals,
                                        const torch::Tensor& means, const handscs::FacingCull& cull) {
  const auto l = linear.to(torch::kFloat64), n = normals.to(torch::kFloat64);
  const auto x = means.to(torch::kFloat64);
  const auto carried = l.matmul(n.unsqueeze(2)).squeeze(2);
  auto smallest = torch::full({x.size(0)}, INFINITY, torch::kFloat64);
  for (const auto& c : cull.camera_centres) {
    const auto ray = x - torch::tensor({c[0], c[1], c[2]}, torch::kFloat64);
    const auto lengths = carried.norm(2, 1) * ray.norm(2, 1);
    const auto cosine = torch::where(lengths == 0, torch::full_like(lengths, -INFINITY),
                                     (carried * ray).sum(1) / lengths);
    smallest = torch::minimum(smallest, cosine);
  }
  return smallest;
}

// The kept rows by the definition: any camera with cos <= max_cos.
torch::Tensor facing_reference(const torch::Tensor& linear, const torch::Tensor& normals,
                               const torch::Tensor& means, const handscs::FacingCull& cull) {
  return (smallest_cosine_reference(linear, normals, means, cull) <= cull.max_cos).nonzero().squeeze(1);
}

// Random blend 3x3s, rest normals and centres ~0.1 m around the origin, in double.
std::tuple<torch::Tensor, torch::Tensor, torch::Tensor> random_cull_inputs(uint64_t seed, int64_t n) {
  auto gen = at::detail::createCPUGenerator(seed);
  auto linear = at::normal(0.0, 1.0, {n, 3, 3}, gen, torch::kFloat64);
  auto normals = at::normal(0.0, 1.0, {n, 3}, gen, torch::kFloat64);
  auto means = at::normal(0.0, 0.1, {n, 3}, gen, torch::kFloat64);
  return {linear, normals, means};
}

}  // namespace

TEST_CASE("facing cull: rest normals of an octahedron point along its axes") {
  handscs::Rig rig;
  rig.v_template = torch::tensor({1., 0., 0., -1., 0., 0., 0., 1., 0., 0., -1., 0., 0., 0., 1., 0., 0., -1.,
                                  5., 5., 5.},  // the last vertex belongs to no face
                                 torch::kFloat64)
                       .view({7, 3});
  // Counter-clockwise seen from outside: (+x, +y, +z) and its images under the axis reflections.
  std::vector<int64_t> faces;
  for (const int sx : {0, 1})
    for (const int sy : {2, 3})
      for (const int sz : {4, 5}) {
        const bool flipped = (sx == 1) ^ (sy == 3) ^ (sz == 5);  // an odd reflection reverses order
        if (flipped)
          faces.insert(faces.end(), {sx, sz, sy});
        else
          faces.insert(faces.end(), {sx, sy, sz});
      }
  rig.faces = torch::tensor(faces, torch::kInt64).view({8, 3});
  const auto normals = handscs::rest_vertex_normals(rig);
  auto expected = rig.v_template.clone();
  expected[6].zero_();
  CHECK(torch::allclose(normals, expected, 0, 1e-15));
  // Clockwise faces (a rig file with the other winding): still outward.
  rig.faces = rig.faces.flip(1).contiguous();
  CHECK(torch::allclose(handscs::rest_vertex_normals(rig), expected, 0, 1e-15));
}

TEST_CASE("facing cull: kept rows equal the brute-force definition") {
  auto gen = at::detail::createCPUGenerator(11);
  const int64_t n = 4000;
  for (const auto dtype : {torch::kFloat64, torch::kFloat32}) {
    // The 3x3s as a transposed view (strided input); normals and means at random.
    const auto linear = at::normal(0.0, 1.0, {n, 3, 3}, gen, torch::kFloat64).to(dtype).transpose(1, 2);
    auto normals = at::normal(0.0, 1.0, {n, 3}, gen, torch::kFloat64).to(dtype);
    auto means = (at::normal(0.0, 0.1, {n, 3}, gen, torch::kFloat64)).to(dtype);
    normals[5].zero_();                              // zero normal: kept
    means[7] = torch::tensor({0.0, 0.0, -0.6});      // on the first camera: kept
    for (const double max_cos : {0.3, 0.0, -0.5, 0.9}) {
      handscs::FacingCull cull;
      cull.max_cos = max_cos;
      cull.row_multiple = 1;  // the test alone
      cull.camera_centres = {{0, 0, -0.6}, {0.5, 0.1, 0.2}};
      const auto rows = handscs::facing_rows(linear, normals, means, cull);
      auto expected = facing_reference(linear, normals, means, cull);
      INFO("max_cos " << max_cos << (dtype == torch::kFloat32 ? " float" : " double"));
      // Ties at max_cos within rounding are possible only in principle: none in this draw.
      REQUIRE(rows.sizes() == expected.sizes());
      CHECK(torch::equal(rows, expected));
      CHECK(rows.numel() > 0);
      // One camera keeps a subset of what two keep.
      handscs::FacingCull one = cull;
      one.camera_centres.resize(1);
      const auto fewer = handscs::facing_rows(linear, normals, means, one);
      CHECK(fewer.numel() < n);
      CHECK(torch::isin(fewer, rows).all().item<bool>());
      CHECK(torch::equal(fewer, facing_reference(linear, normals, means, one)));
    }
  }
}

TEST_CASE("facing cull: the kept count is rounded up with the culled rows nearest the threshold") {
  const int64_t n = 1000;
  const auto [linear, normals, means] = random_cull_inputs(12, n);
  handscs::FacingCull cull;
  cull.camera_centres = {{0, 0, -0.6}};
  const auto cosine = smallest_cosine_reference(linear, normals, means, cull);
  const auto exact = facing_reference(linear, normals, means, cull);
  for (const int64_t multiple : {64, 128, 7, 1000, 4096}) {
    cull.row_multiple = multiple;
    const auto rows = handscs::facing_rows(linear, normals, means, cull);
    const int64_t k = exact.numel();
    INFO("multiple " << multiple << ", " << k << " pass the test");
    CHECK(rows.numel() == std::min<int64_t>(std::max<int64_t>((k + multiple - 1) / multiple, 1) * multiple, n));
    CHECK(torch::equal(std::get<0>(rows.sort()), rows));  // increasing
    CHECK(torch::isin(exact, rows).all().item<bool>());
    // Every added row is nearer the threshold than every row still culled.
    const auto added = rows.index({torch::isin(rows, exact).logical_not()});
    auto still_culled = torch::ones({n}, torch::kBool);
    still_culled.index_fill_(0, rows, false);
    if (added.numel() > 0 && still_culled.any().item<bool>())
      CHECK(cosine.index_select(0, added).max().item<double>() <=
            cosine.index({still_culled}).min().item<double>());
  }
}

TEST_CASE("facing cull: a test that culls every Gaussian still keeps one multiple") {
  const int64_t n = 500;
  const auto [linear, normals, means] = random_cull_inputs(13, n);
  handscs::FacingCull cull;
  cull.camera_centres = {{0, 0, -0.6}};
  cull.max_cos = -1.0;  // only a normal pointing straight at the camera passes
  REQUIRE(facing_reference(linear, normals, means, cull).numel() == 0);
  const auto cosine = smallest_cosine_reference(linear, normals, means, cull);
  cull.row_multiple = 64;
  const auto rows = handscs::facing_rows(linear, normals, means, cull);
  REQUIRE(rows.numel() == 64);
  // The 64 smallest cosines.
  CHECK(torch::equal(rows, std::get<0>(std::get<1>(cosine.topk(64, 0, false)).sort())));
  cull.row_multiple = 1000;  // more than N: every row
  CHECK(handscs::facing_rows(linear, normals, means, cull).numel() == n);
}

TEST_CASE("facing cull: non-finite rows are kept, bad arguments are refused") {
  const auto linear = torch::eye(3, torch::kFloat64).expand({3, 3, 3}).contiguous();
  auto normals = torch::tensor({0., 0., 1., 0., 0., 1., 0., 0., 1.}, torch::kFloat64).view({3, 3});
  auto means = torch::zeros({3, 3}, torch::kFloat64);
  handscs::FacingCull cull;
  cull.row_multiple = 1;
  cull.camera_centres = {{0, 0, -1}};  // every normal points away from this camera
  CHECK(handscs::facing_rows(linear, normals, means, cull).numel() == 1);  // one "multiple" of 1
  means[1][0] = std::nan("");
  normals[2][2] = INFINITY;
  CHECK(torch::equal(handscs::facing_rows(linear, normals, means, cull), torch::tensor({1, 2}, torch::kInt64)));
  handscs::FacingCull none;
  CHECK_THROWS_AS(handscs::facing_rows(linear, normals, means, none), handscs::Error);
  cull.max_cos = 1.5;
  CHECK_THROWS_AS(handscs::facing_rows(linear, normals, means, cull), handscs::Error);
  cull.max_cos = 0.3;
  CHECK_THROWS_AS(handscs::facing_rows(linear, normals.slice(0, 0, 2), means, cull), handscs::Error);
}

TEST_CASE("facing cull: the culled pose renders and differentiates as the exact pose without its culled Gaussians") {
  auto avatar = handscs_test::small_double_avatar();
  {
    torch::NoGradGuard no_grad;  // anisotropic, so rotations matter
    avatar.gaussians().log_scales.add_(torch::randn_like(avatar.gaussians().log_scales) * 0.3);
  }
  const auto pose = torch::randn({48}, torch::kFloat64) * 0.2;
  const auto shape = torch::zeros({10}, torch::kFloat64);
  const auto trans = torch::zeros({3}, torch::kFloat64);
  const auto camera = handscs_test::hand_view_camera(80, 64);
  handscs::FacingCull cull;
  cull.camera_centres = {camera.centre()};
  const auto cotangent = torch::rand({64, 80, 3}, torch::kFloat64);

  auto gradients = [&](const handscs::AvatarState& state, const torch::Tensor& opacities) {
    handscs::PosedGaussians posed = state.posed;
    posed.opacities = opacities;
    const auto render = handscs::render_posed(posed, camera, {});
    ((render.rgb * cotangent).sum() + render.alpha.sum()).backward();
    std::vector<torch::Tensor> grads{render.rgb.detach(), render.alpha.detach()};
    for (auto& [name, tensor] : avatar.gaussians().learnable()) {
      grads.push_back(tensor->grad().defined() ? tensor->grad().clone() : torch::zeros_like(*tensor));
      tensor->mutable_grad().reset();
    }
    for (auto& p : avatar.decoders()->parameters()) {
      grads.push_back(p.grad().defined() ? p.grad().clone() : torch::zeros_like(p));
      p.mutable_grad().reset();
    }
    return grads;
  };
  const auto culled = avatar.pose(pose, shape, trans, false, &cull);
  REQUIRE(culled.decoded_rows.defined());
  const int64_t n = avatar.gaussians().size();
  const int64_t kept = culled.decoded_rows.numel();
  CHECK(kept > n / 4);
  CHECK(kept < n);
  const auto mask = torch::zeros({n}, torch::kFloat64).index_fill_(0, culled.decoded_rows, 1.0);
  // Culled rows: transparent, no offsets.
  CHECK((culled.posed.opacities * (1 - mask)).abs().max().item<double>() == 0);
  CHECK(torch::equal(culled.offsets.dx.index_select(0, (mask == 0).nonzero().squeeze(1)),
                     torch::zeros({n - kept, 3}, torch::kFloat64)));
  const auto with_cull = gradients(culled, culled.posed.opacities);
  const auto exact = avatar.pose(pose, shape, trans);
  const auto reference = gradients(exact, exact.posed.opacities * mask);
  REQUIRE(with_cull.size() == reference.size());
  for (size_t k = 0; k < reference.size(); ++k) {
    INFO("tensor " << k);
    const double scale = reference[k].abs().max().item<double>();
    CHECK(scale > 0);
    CHECK((with_cull[k] - reference[k]).abs().max().item<double>() <= 1e-10 * scale);
  }
  // Kept rows decode as in the exact pose.
  CHECK(torch::allclose(culled.posed.means.index_select(0, culled.decoded_rows),
                        exact.posed.means.index_select(0, culled.decoded_rows), 1e-12, 1e-14));

  // Every Gaussian facing: nothing culled, the exact pose bit for bit.
  cull.max_cos = 1.0;
  const auto all = avatar.pose(pose, shape, trans, false, &cull);
  CHECK_FALSE(all.decoded_rows.defined());
  CHECK(torch::equal(all.posed.means, exact.posed.means));
  CHECK(torch::equal(all.posed.opacities, exact.posed.opacities));

  // Inference (frozen decoders): the kept rows as in the exact inference pose, the others
  // transparent.
  torch::NoGradGuard no_grad;
  cull.max_cos = 0.3;
  const auto frozen_culled = avatar.pose(pose, shape, trans, false, &cull);
  const auto frozen_exact = avatar.pose(pose, shape, trans);
  REQUIRE(frozen_culled.decoded_rows.defined());
  CHECK(torch::equal(frozen_culled.decoded_rows, culled.decoded_rows));
  const auto& rows = frozen_culled.decoded_rows;
  CHECK(torch::allclose(frozen_culled.posed.means.index_select(0, rows),
                        frozen_exact.posed.means.index_select(0, rows), 1e-12, 1e-14));
  CHECK(torch::allclose(frozen_culled.posed.covariances.index_select(0, rows),
                        frozen_exact.posed.covariances.index_select(0, rows), 1e-12, 1e-16));
  CHECK(torch::equal(frozen_culled.posed.opacities, frozen_exact.posed.opacities * mask));
}
