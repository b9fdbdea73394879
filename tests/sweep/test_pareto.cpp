// Pareto front: hand-built point sets with known fronts (ties, duplicates, NaN, both directions of y)
// and agreement with the O(n^2) definition on random points with many ties.
#include <catch2/catch.hpp>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "core/error.h"
#include "sweep/pareto.h"

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

// The definition, point by point: i is on the front when it is finite and no finite j is at least as
// good in both (lower x, better y) and strictly better in one. Sorted by x, then index.
std::vector<size_t> brute_force_front(const std::vector<double>& x, const std::vector<double>& y, bool maximize_y) {
  auto finite = [&](size_t i) { return std::isfinite(x[i]) && std::isfinite(y[i]); };
  auto at_least_as_good_y = [&](size_t j, size_t i) { return maximize_y ? y[j] >= y[i] : y[j] <= y[i]; };
  auto better_y = [&](size_t j, size_t i) { return maximize_y ? y[j] > y[i] : y[j] < y[i]; };
  std::vector<size_t> front;
  for (size_t i = 0; i < x.size(); ++i) {
    if (!finite(i)) continue;
    bool dominated = false;
    for (size_t j = 0; j < x.size() && !dominated; ++j)
      dominated = j != i && finite(j) && x[j] <= x[i] && at_least_as_good_y(j, i) && (x[j] < x[i] || better_y(j, i));
    if (!dominated) front.push_back(i);
  }
  std::stable_sort(front.begin(), front.end(), [&](size_t a, size_t b) { return x[a] < x[b]; });
  return front;
}

using Indices = std::vector<size_t>;

}  // namespace

TEST_CASE("pareto_front of a staircase keeps the non-dominated points, cheapest first", "[pareto]") {
  // Wall time vs PSNR. Point 3 (3 s, 27 dB) loses to point 1 (2 s, 28 dB); point 4 (5 s, 28 dB) ties
  // point 1 in quality at a higher cost; point 5 is the slowest but the best.
  const std::vector<double> seconds = {4.0, 2.0, 1.0, 3.0, 5.0, 6.0};
  const std::vector<double> psnr = {30.0, 28.0, 25.0, 27.0, 28.0, 31.0};
  CHECK(handscs::pareto_front(seconds, psnr, true) == Indices{2, 1, 0, 5});
  // Minimising y instead (LPIPS-like): only the cheapest point, which also has the lowest y, survives.
  CHECK(handscs::pareto_front(seconds, psnr, false) == Indices{2});
}

TEST_CASE("pareto_front when minimising y", "[pareto]") {
  // Wall time vs LPIPS (lower is better): (1, 0.30), (2, 0.20), (3, 0.25) dominated by (2, 0.20),
  // (4, 0.10), (4, 0.15) dominated by (4, 0.10) at the same cost.
  const std::vector<double> seconds = {1, 2, 3, 4, 4};
  const std::vector<double> lpips = {0.30, 0.20, 0.25, 0.10, 0.15};
  CHECK(handscs::pareto_front(seconds, lpips, false) == Indices{0, 1, 3});
  CHECK(handscs::pareto_front(seconds, lpips, true) == Indices{0});
}

TEST_CASE("pareto_front keeps identical points and drops ties that are worse in one coordinate", "[pareto]") {
  // (1, 5) twice: neither dominates the other, both stay, by index. (1, 4) has the same cost and lower
  // quality; (2, 5) the same quality at a higher cost; (3, 6) is better.
  const std::vector<double> x = {1, 2, 1, 1, 3};
  const std::vector<double> y = {5, 5, 5, 4, 6};
  CHECK(handscs::pareto_front(x, y, true) == Indices{0, 2, 4});
  // Minimising y: (1, 4) is the unique best at the lowest cost and dominates everything else.
  CHECK(handscs::pareto_front(x, y, false) == Indices{3});
  // All points equal: all on the front.
  CHECK(handscs::pareto_front({2, 2, 2}, {7, 7, 7}, true) == Indices{0, 1, 2});
}

TEST_CASE("pareto_front never puts a non-finite point on the front, and ignores it as a dominator", "[pareto]") {
  // (NaN, 100) and (0.5, inf) would dominate everything if they counted; (-inf, 1) too.
  const std::vector<double> x = {kNaN, 1, 2, 0.5, -kInf, 3};
  const std::vector<double> y = {100, 10, 20, kInf, 1, kNaN};
  CHECK(handscs::pareto_front(x, y, true) == Indices{1, 2});
  CHECK(handscs::pareto_front(x, y, false) == Indices{1});
  CHECK(handscs::pareto_front({kNaN, 1}, {1, kNaN}, true).empty());
  CHECK(handscs::pareto_front({}, {}, true).empty());
  CHECK(handscs::pareto_front({3}, {-2}, false) == Indices{0});
}

TEST_CASE("pareto_front rejects x and y of different lengths", "[pareto]") {
  CHECK_THROWS_AS(handscs::pareto_front({1, 2}, {1}, true), handscs::Error);
  CHECK_THROWS_WITH(handscs::pareto_front({1, 2}, {1}, true), "pareto_front: x has 2 values, y has 1");
}

TEST_CASE("pareto_front agrees with the O(n^2) definition on 200 random points", "[pareto]") {
  std::mt19937 rng(20240611);
  for (int trial = 0; trial < 20; ++trial) {
    // Coordinates on a coarse grid (many ties and duplicates), a few NaN and infinities.
    std::vector<double> x(200), y(200);
    for (size_t i = 0; i < x.size(); ++i) {
      x[i] = double(rng() % 25) * 0.5;
      y[i] = double(int(rng() % 30) - 10) * 0.25;
      const unsigned special = rng() % 50;
      if (special == 0) x[i] = kNaN;
      if (special == 1) y[i] = kNaN;
      if (special == 2) y[i] = -kInf;
    }
    for (bool maximize : {true, false}) {
      INFO("trial " << trial << " maximize_y " << maximize);
      const auto front = handscs::pareto_front(x, y, maximize);
      CHECK(front == brute_force_front(x, y, maximize));
      CHECK(!front.empty());
    }
  }
}
