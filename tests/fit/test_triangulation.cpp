// Triangulation against independent references: the exact point from noise-free views, a
// brute-force grid minimum of the reprojection error from noisy ones, and the views a robust
// triangulation must drop.
#include <catch2/catch.hpp>

#include <limits>

#include "fit/triangulation.h"
#include "fit_fixtures.h"

using namespace handscs;

namespace {

double squared_error(const std::vector<Camera>& cameras, const std::vector<Observation>& obs, const Vec3& X) {
  double sum = 0;
  for (const Observation& o : obs) {
    const double e = reprojection_error(cameras[o.view], X, o.pixel);
    sum += e * e;
  }
  return sum;
}

std::vector<Observation> observe(const std::vector<Camera>& cameras, const Vec3& X, double noise_px,
                                 std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, noise_px);
  std::vector<Observation> obs;
  for (int v = 0; v < static_cast<int>(cameras.size()); ++v) {
    const auto uv = cameras[v].project_camera(cameras[v].to_camera(X));
    obs.push_back({v, {uv[0] + n(rng), uv[1] + n(rng)}});
  }
  return obs;
}

}  // namespace

TEST_CASE("triangulate: noise-free views give the point back") {
  const auto cameras = test::camera_ring(6);
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> u(-0.15, 0.15);
  for (int trial = 0; trial < 20; ++trial) {
    const Vec3 X{u(rng), u(rng), u(rng)};
    Vec3 got;
    REQUIRE(triangulate(cameras, observe(cameras, X, 0.0, rng), got));
    CHECK(norm(got - X) < 1e-9);
  }
  // Two views suffice; one does not.
  const Vec3 X{0.02, -0.01, 0.03};
  auto obs = observe(cameras, X, 0.0, rng);
  Vec3 got;
  CHECK(triangulate(cameras, {obs[0], obs[2]}, got));
  CHECK(norm(got - X) < 1e-9);
  CHECK_FALSE(triangulate(cameras, {obs[0]}, got));
}

TEST_CASE("triangulate: noisy views give the minimum of the reprojection error (brute-force grid)") {
  const auto cameras = test::camera_ring(5);
  std::mt19937 rng(2);
  for (int trial = 0; trial < 3; ++trial) {
    const auto obs = observe(cameras, {0.01 * trial, -0.02, 0.015}, 3.0, rng);
    Vec3 got;
    REQUIRE(triangulate(cameras, obs, got));
    // A 2 mm cube around the answer at 0.05 mm steps: no grid point does better, and the best one
    // lies within a step of the answer.
    const double step = 5e-5;
    double best = std::numeric_limits<double>::infinity();
    Vec3 best_point{};
    for (int i = -20; i <= 20; ++i)
      for (int j = -20; j <= 20; ++j)
        for (int k = -20; k <= 20; ++k) {
          const Vec3 X = got + Vec3{i * step, j * step, k * step};
          const double e = squared_error(cameras, obs, X);
          if (e < best) {
            best = e;
            best_point = X;
          }
        }
    CHECK(squared_error(cameras, obs, got) <= best + 1e-9);
    CHECK(norm(best_point - got) <= step * std::sqrt(3.0));
  }
}

TEST_CASE("triangulate_robust: drops exactly the views that disagree") {
  const auto cameras = test::camera_ring(8);
  std::mt19937 rng(3);
  const Vec3 X{0.03, 0.01, -0.02};
  auto obs = observe(cameras, X, 1.0, rng);
  obs[2].pixel[0] += 120.0;  // a mislabelled landmark
  obs[5].pixel[1] -= 80.0;
  const RobustPoint p = triangulate_robust(cameras, obs, 30.0);
  REQUIRE(p.ok);
  CHECK(p.dropped == std::vector<int>{2, 5});
  std::vector<Observation> clean;
  for (int i : p.inliers) clean.push_back(obs[i]);
  Vec3 reference;
  REQUIRE(triangulate(cameras, clean, reference));
  CHECK(norm(p.point - reference) < 1e-9);
  CHECK(norm(p.point - X) < 1e-3);
  // One view fixes no point.
  CHECK_FALSE(triangulate_robust(cameras, {obs[0]}, 30.0).ok);
}
