// Inter-pose consistency pieces against plain-loop references: the pose feature and similarity,
// the exact correspondence search, the canonical K-NN and the candidate search (which must return
// the exact argmin whenever it is among the candidates, and equal the exact search at K = N), and
// the three searches row for row on twins closer than float32 rounding.
#include "catch_torch.h"

#include <cmath>
#include <limits>

#include "avatar/avatar.h"
#include "hand/lbs.h"
#include "pose_descriptors.h"
#include "train/consistency.h"
#include "train/descriptor_tree.h"

namespace {

// argmin_j |q_i - r_j|^2 by plain loops in double.
std::vector<int64_t> brute_argmin(const torch::Tensor& q, const torch::Tensor& r) {
  const auto qa = q.to(torch::kFloat64).contiguous(), ra = r.to(torch::kFloat64).contiguous();
  std::vector<int64_t> out;
  for (int64_t i = 0; i < qa.size(0); ++i) {
    double best = std::numeric_limits<double>::infinity();
    int64_t arg = -1;
    for (int64_t j = 0; j < ra.size(0); ++j) {
      const double d = (qa[i] - ra[j]).pow(2).sum().item<double>();
      if (d < best) best = d, arg = j;
    }
    out.push_back(arg);
  }
  return out;
}

}  // namespace

TEST_CASE("consistency: pose feature is R - I of the finger joints, similarity is a Gaussian") {
  auto pose = torch::zeros({48}, torch::kFloat64);
  CHECK(handscs::pose_feature(pose).abs().max().item<double>() == 0.0);
  pose[3 + 5] = 0.5;  // joint 2 (index 1 of the fingers), z rotation of 0.5 rad
  const auto f = handscs::pose_feature(pose).view({15, 3, 3});
  CHECK(f.size(0) == 15);
  CHECK(f[1][0][0].item<double>() == Approx(std::cos(0.5) - 1.0).margin(1e-12));
  CHECK(f[1][0][1].item<double>() == Approx(-std::sin(0.5)).margin(1e-12));
  CHECK(f[0].abs().max().item<double>() == 0.0);
  const auto zero = handscs::pose_feature(torch::zeros({48}, torch::kFloat64));
  const double sq = (handscs::pose_feature(pose) - zero).pow(2).sum().item<double>();
  CHECK(handscs::pose_similarity(handscs::pose_feature(pose), zero, 1.3) ==
        Approx(std::exp(-sq / (2 * 1.3 * 1.3))).epsilon(1e-12));
  CHECK(handscs::pose_similarity(zero, zero, 1.3) == 1.0);
}

TEST_CASE("consistency: exact search, K-NN and candidate search match plain loops") {
  torch::manual_seed(3);
  // 1500 rows: more than one block of the exact search (1024), so the blocking is exercised.
  const auto reference = torch::randn({1500, 6});
  const auto query = reference + 0.3 * torch::randn({1500, 6});
  const auto exact = handscs::correspond_exact(query, reference);
  const auto q_sub = query.slice(0, 0, 1500, 37), exact_sub = exact.slice(0, 0, 1500, 37);
  const auto brute = brute_argmin(q_sub, reference);
  for (size_t i = 0; i < brute.size(); ++i) CHECK(exact_sub[i].item<int64_t>() == brute[i]);

  const auto points = torch::rand({300, 3});
  const auto knn = handscs::nearest_neighbours(points, 8);
  REQUIRE(knn.sizes() == torch::IntArrayRef({300, 8}));
  const auto d_all = (points.unsqueeze(1) - points.unsqueeze(0)).pow(2).sum(2);  // [300, 300]
  for (int64_t i = 0; i < 300; i += 29) {
    CHECK(knn[i][0].item<int64_t>() == i);  // itself first
    const auto sorted = std::get<0>(d_all[i].sort());
    const auto got = d_all[i].index_select(0, knn[i]);
    CHECK(torch::allclose(got, sorted.slice(0, 0, 8), 1e-6, 1e-7));
  }

  // Candidate search: at K = N it is the exact search; with a candidate set that contains the
  // exact argmin it returns it; it never returns an index outside the set.
  const auto small_q = query.slice(0, 0, 200), small_r = reference.slice(0, 0, 200);
  const auto all = torch::arange(200, torch::kInt64).unsqueeze(0).expand({200, 200}).contiguous();
  CHECK(torch::equal(handscs::correspond_candidates(small_q, small_r, all),
                     handscs::correspond_exact(small_q, small_r)));
  const auto truth = handscs::correspond_exact(small_q, small_r);
  auto candidates = torch::randint(200, {200, 5}, torch::kInt64);
  candidates.select(1, 2).copy_(truth);
  CHECK(torch::equal(handscs::correspond_candidates(small_q, small_r, candidates), truth));
  const auto without = torch::randint(200, {200, 4}, torch::kInt64);
  const auto picked = handscs::correspond_candidates(small_q, small_r, without);
  CHECK(torch::equal(picked, without.gather(1, (without == picked.unsqueeze(1)).to(torch::kInt64)
                                                    .argmax(1, true)).squeeze(1)));
}

TEST_CASE("consistency: the GEMM, the k-d tree and the candidate search agree row for row on near-ties") {
  // Twins closer than float32 rounding can tell apart: each reference row has a twin 1e-6 away
  // (every fifth an exact copy), and all rows sit far from the origin, so the GEMM's |r|^2 - 2 q.r
  // cancels. Every search must return the brute-force argmin in double, ties to the lowest row.
  torch::manual_seed(11);
  const int64_t base = 300, d = 36;
  const auto centre = torch::full({1, d}, 0.8);
  const auto rows = centre + 0.05 * torch::randn({base, d});
  auto twins = rows + 1e-6 * torch::randn({base, d});
  twins.slice(0, 0, base, 5).copy_(rows.slice(0, 0, base, 5));
  const auto reference = torch::cat({rows, twins});                            // float32 [600, 36]
  const auto query = rows.slice(0, 0, base, 2) + 0.01 * torch::randn({base / 2, d});

  // argmin_j |q_i - r_j|^2 by plain loops in double, the lowest j of equal distances.
  const auto q64 = query.to(torch::kFloat64).contiguous(), r64 = reference.to(torch::kFloat64).contiguous();
  std::vector<int64_t> truth;
  int64_t twin_matches = 0;
  for (int64_t i = 0; i < q64.size(0); ++i) {
    double best = std::numeric_limits<double>::infinity();
    int64_t arg = -1;
    for (int64_t j = 0; j < r64.size(0); ++j) {
      double dist = 0;
      for (int64_t e = 0; e < d; ++e) {
        const double diff = q64.data_ptr<double>()[i * d + e] - r64.data_ptr<double>()[j * d + e];
        dist += diff * diff;
      }
      if (dist < best) best = dist, arg = j;
    }
    truth.push_back(arg);
    twin_matches += arg >= base ? 1 : 0;
  }
  // The set-up is a test of near-ties only if some twins win.
  INFO("queries matched to a twin: " << twin_matches);
  CHECK(twin_matches > 10);

  const auto all = torch::arange(2 * base, torch::kInt64).unsqueeze(0).expand({base / 2, 2 * base}).contiguous();
  const auto own = torch::arange(0, base, 2, torch::kInt64);
  for (const auto& [name, match] :
       {std::pair{"GEMM", handscs::correspond_exact(query, reference)},
        std::pair{"k-d tree", handscs::DescriptorTree(reference).nearest(query)},
        std::pair{"k-d tree with a guess", handscs::DescriptorTree(reference).nearest(query, own)},
        std::pair{"every row a candidate", handscs::correspond_candidates(query, reference, all)}}) {
    int64_t wrong = 0;
    for (int64_t i = 0; i < match.size(0); ++i) wrong += match[i].item<int64_t>() != truth[i] ? 1 : 0;
    INFO(name << ": rows off the brute-force argmin: " << wrong);
    CHECK(wrong == 0);
  }
}

TEST_CASE("consistency: on the built-in hand's descriptors, candidates approach the exact argmin") {
  // Two different poses of an untrained avatar: the K-NN sets are nested, so the agreement of the
  // candidate search with the exact one can only grow with K (the trained-avatar figures:
  // docs/BENCHMARKS.md#correspondence-search).
  torch::NoGradGuard no_grad;
  handscs::Avatar avatar(handscs::AvatarConfig{}, handscs::load_rig_source("builtin"));
  const auto [a, b] = handscs_test::two_pose_descriptors(avatar);
  const auto exact = handscs::correspond_exact(a, b);
  const auto& means = avatar.gaussians().means;
  double previous = 0;
  for (int64_t k : {8, 32, 128}) {
    const auto match = handscs::correspond_candidates(a, b, handscs::nearest_neighbours(means, k));
    const double agreement = match.eq(exact).to(torch::kFloat64).mean().item<double>();
    INFO("K = " << k << ": agreement " << agreement);
    CHECK(agreement >= previous);
    previous = agreement;
  }
}

TEST_CASE("consistency: attribute distances, raw and per group normalised, match plain loops") {
  const int64_t n = 7, d = 4, width = 15 + 2 * d;
  torch::manual_seed(5);
  const auto attributes = torch::randn({n, width}, torch::kFloat64);
  const auto matched = torch::randn({n, width}, torch::kFloat64);
  // SPD covariances of millimetre-sized Gaussians.
  const auto a = torch::randn({n, 3, 3}, torch::kFloat64) * 2e-3;
  const auto covariances = a.matmul(a.transpose(1, 2)) + torch::eye(3, torch::kFloat64) * 1e-7;

  const auto raw = handscs::consistency_distances(attributes, matched, covariances, handscs::ConsistencyConfig::Normalize::none);
  const auto grouped = handscs::consistency_distances(attributes, matched, covariances, handscs::ConsistencyConfig::Normalize::groups);
  for (int64_t i = 0; i < n; ++i) {
    double sums[4] = {0, 0, 0, 0};
    double all = 0;
    for (int64_t k = 0; k < width; ++k) {
      const double diff = attributes[i][k].item<double>() - matched[i][k].item<double>();
      all += diff * diff;
      sums[k < 3 ? 0 : k < 12 ? 1 : k < 15 ? 2 : 3] += diff * diff;
    }
    double trace = 0;
    for (int c = 0; c < 3; ++c) trace += covariances[i][c][c].item<double>();
    const double s2 = trace / 3;
    const double expected = sums[0] / (3 * s2) + sums[1] / (9 * s2 * s2) + sums[2] / 3 + sums[3] / (2 * d);
    CHECK_THAT(raw[i].item<double>(), Catch::Matchers::WithinRel(all, 1e-12));
    CHECK_THAT(grouped[i].item<double>(), Catch::Matchers::WithinRel(expected, 1e-12));
  }

  // The gradient in the attributes against central differences (the extent is a constant). Unit
  // extents keep every group of the same order, so the differences are not lost to rounding.
  const auto unit = torch::eye(3, torch::kFloat64).expand({n, 3, 3}).clone();
  const auto x = attributes.clone().requires_grad_(true);
  handscs::consistency_distances(x, matched, unit, handscs::ConsistencyConfig::Normalize::groups).sum().backward();
  const double h = 1e-6;
  for (int64_t k : {0L, 5L, 13L, 20L}) {
    auto plus = attributes.clone(), minus = attributes.clone();
    plus[2][k] += h;
    minus[2][k] -= h;
    const double fd = (handscs::consistency_distances(plus, matched, unit, handscs::ConsistencyConfig::Normalize::groups).sum() -
                       handscs::consistency_distances(minus, matched, unit, handscs::ConsistencyConfig::Normalize::groups).sum())
                          .item<double>() / (2 * h);
    CHECK_THAT(x.grad()[2][k].item<double>(), Catch::Matchers::WithinRel(fd, 1e-6));
  }
}

TEST_CASE("consistency: with train.cull a pair counts only when both of its Gaussians were decoded") {
  const auto match = torch::tensor({3, 0, 0, 2, 1}, torch::kInt64);
  const auto now = torch::tensor({true, true, false, true, true});
  const auto prev = torch::tensor({true, false, true, false});  // previous step: 4 Gaussians
  // By hand: i = 0 (3: not decoded before), 1 (0: yes), 2 (not now), 3 (2: yes), 4 (1: no).
  CHECK(torch::equal(handscs::pairs_decoded_at_both_steps(now, prev, match), torch::tensor({1, 3}, torch::kInt64)));
  CHECK(torch::equal(handscs::pairs_decoded_at_both_steps(now, {}, match), torch::tensor({0, 1, 3, 4}, torch::kInt64)));
  CHECK(torch::equal(handscs::pairs_decoded_at_both_steps({}, prev, match), torch::tensor({1, 2, 3}, torch::kInt64)));
  CHECK(torch::equal(handscs::pairs_decoded_at_both_steps({}, {}, match), torch::arange(5, torch::kInt64)));
}
