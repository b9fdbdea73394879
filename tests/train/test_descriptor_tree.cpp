// The exact k-d tree search of L_con's correspondences against brute force (plain loops in double):
// on points of a 3-D surface curled into 36 dimensions, on the built-in hand's descriptors at two
// poses, with no guess, the right guess and a poor one, and on degenerate input.
#include "catch_torch.h"

#include <limits>

#include "avatar/avatar.h"
#include "core/error.h"
#include "pose_descriptors.h"
#include "train/descriptor_tree.h"

namespace {

// min_j |q_i - r_j|^2 by plain loops in double: [N].
std::vector<double> brute_min_distance(const torch::Tensor& query, const torch::Tensor& reference) {
  const auto q = query.to(torch::kFloat64).contiguous(), r = reference.to(torch::kFloat64).contiguous();
  const double* qp = q.data_ptr<double>();
  const double* rp = r.data_ptr<double>();
  const int64_t d = q.size(1);
  std::vector<double> out(q.size(0), std::numeric_limits<double>::infinity());
  for (int64_t i = 0; i < q.size(0); ++i)
    for (int64_t j = 0; j < r.size(0); ++j) {
      double dist = 0;
      for (int64_t e = 0; e < d; ++e) dist += (qp[i * d + e] - rp[j * d + e]) * (qp[i * d + e] - rp[j * d + e]);
      out[i] = std::min(out[i], dist);
    }
  return out;
}

// Share of rows whose match is at the brute-force minimum distance (ties count: either row is an
// argmin), up to float rounding of the distances.
double exact_share(const torch::Tensor& query, const torch::Tensor& reference, const torch::Tensor& match) {
  const auto best = brute_min_distance(query, reference);
  const auto q = query.to(torch::kFloat64), r = reference.to(torch::kFloat64);
  const auto got = (q - r.index_select(0, match)).pow(2).sum(1);
  int64_t exact = 0;
  for (int64_t i = 0; i < q.size(0); ++i)
    exact += got[i].item<double>() <= best[i] * (1 + 1e-5) + 1e-12 ? 1 : 0;
  return static_cast<double>(exact) / q.size(0);
}

// Points of a 3-D manifold in 36-D, as descriptors are: smooth functions of a 3-D position.
torch::Tensor curled_surface(int64_t n, uint64_t seed) {
  auto gen = at::detail::createCPUGenerator(seed);
  const auto x = at::rand({n, 3}, gen, torch::kFloat32) * 0.2;
  std::vector<torch::Tensor> columns;
  for (int k = 0; k < 12; ++k) {
    const auto w = at::randn({3}, gen, torch::kFloat32) * 20;
    const auto phase = (x * w).sum(1);
    columns.push_back(torch::sin(phase) * 0.05);
    columns.push_back(torch::cos(phase) * 0.05);
    columns.push_back(phase * 0.01);
  }
  return torch::stack(columns, 1);
}

}  // namespace

TEST_CASE("descriptor tree: exact on a 3-D surface in 36-D, with or without a guess") {
  const auto reference = curled_surface(1500, 1);
  const auto query = curled_surface(1200, 2);
  const handscs::DescriptorTree tree(reference);
  CHECK(tree.size() == 1500);
  CHECK(tree.dim() == 36);
  CHECK(exact_share(query, reference, tree.nearest(query)) == 1.0);
  // A poor first guess (a fixed far row) and random guesses change the route, not the answer.
  CHECK(exact_share(query, reference, tree.nearest(query, torch::full({1200}, 7, torch::kInt64))) == 1.0);
  CHECK(exact_share(query, reference, tree.nearest(query, torch::randint(1500, {1200}, torch::kInt64))) == 1.0);
  // Every reference row finds itself.
  CHECK(torch::equal(tree.nearest(reference), torch::arange(1500, torch::kInt64)));
}

TEST_CASE("descriptor tree: exact on the built-in hand's descriptors at two poses") {
  torch::NoGradGuard no_grad;
  handscs::Avatar avatar(handscs::AvatarConfig{}, handscs::load_rig_source("builtin"));
  const auto [a, b] = handscs_test::two_pose_descriptors(avatar);
  const handscs::DescriptorTree tree(b);
  const auto guess = torch::arange(a.size(0), torch::kInt64);  // as the trainer guesses
  CHECK(exact_share(a, b, tree.nearest(a, guess)) == 1.0);
}

TEST_CASE("descriptor tree: duplicates, one dimension, one row, empty and bad input") {
  const auto same = torch::ones({40, 5});
  const auto match = handscs::DescriptorTree(same).nearest(torch::zeros({3, 5}));
  CHECK(match.size(0) == 3);
  CHECK(((match >= 0) & (match < 40)).all().item<bool>());

  const auto line = torch::linspace(0, 1, 101).unsqueeze(1);
  const auto found = handscs::DescriptorTree(line).nearest(torch::tensor({{0.304f}, {-5.f}, {0.996f}}));
  CHECK(found[0].item<int64_t>() == 30);
  CHECK(found[1].item<int64_t>() == 0);
  CHECK(found[2].item<int64_t>() == 100);

  CHECK(handscs::DescriptorTree(torch::ones({1, 4})).nearest(torch::randn({6, 4})).eq(0).all().item<bool>());
  CHECK(handscs::DescriptorTree(line).nearest(torch::zeros({0, 1})).size(0) == 0);
  CHECK_THROWS_AS(handscs::DescriptorTree(line).nearest(torch::zeros({2, 3})), handscs::Error);
  CHECK_THROWS_AS(handscs::DescriptorTree(line).nearest(torch::zeros({2, 1}), torch::tensor({0L, 101L})),
                  handscs::Error);
  CHECK_THROWS_AS(handscs::DescriptorTree(torch::zeros({0, 1})).nearest(torch::zeros({2, 1})), handscs::Error);
}
