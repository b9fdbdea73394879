// Training-pose refinement: per-row Adam against a plain loop, the correction's gradient through the
// avatar against finite differences, a planted pose error recovered from renders alone, the
// summary against loops, checkpoint state, and the trainer (exact resume; held-out poses never
// corrected).
#include "catch_torch.h"

#include <cmath>
#include <fstream>
#include <set>
#include <sstream>

#include "avatar/avatar.h"
#include "core/error.h"
#include "core/threads.h"
#include "small_avatar.h"
#include "tiny_capture.h"
#include "train/pose_refine.h"
#include "train/trainer.h"

using handscs::PoseCorrections;

namespace {

handscs::PoseRefineConfig refine_config(double lr, double reg) {
  handscs::PoseRefineConfig c;
  c.enabled = true;
  c.lr = lr;
  c.reg = reg;
  return c;
}

handscs::Camera camera_at(double x, double z) {
  // Looks at the built-in hand (about 0.2 m across around the origin) from (x, 0, z), along -z
  // rotated about y so the hand stays centred.
  handscs::Camera camera;
  camera.width = 64;
  camera.height = 64;
  camera.K = {80, 0, 32, 0, 80, 32, 0, 0, 1};
  const double yaw = std::atan2(x, z);
  camera.R = {std::cos(yaw), 0, -std::sin(yaw), 0, 1, 0, std::sin(yaw), 0, std::cos(yaw)};
  camera.t = {0, 0, std::hypot(x, z)};
  return camera;
}

}  // namespace

TEST_CASE("pose refine: each row's Adam step equals a plain Adam loop, and other rows stay zero") {
  const double lr = 5e-3;
  PoseCorrections corrections(4, refine_config(lr, 0));
  auto gen = at::detail::createCPUGenerator(3);
  std::vector<double> m(51, 0), v(51, 0), x(51, 0);
  for (int t = 1; t <= 5; ++t) {
    const auto grad = at::randn({51}, gen, torch::kFloat64) * std::pow(10.0, -t);
    corrections.step(2, grad);
    for (int k = 0; k < 51; ++k) {
      const double g = grad[k].item<double>();
      m[k] = 0.9 * m[k] + 0.1 * g;
      v[k] = 0.999 * v[k] + 0.001 * g * g;
      const double m_hat = m[k] / (1 - std::pow(0.9, t)), v_hat = v[k] / (1 - std::pow(0.999, t));
      x[k] -= lr * m_hat / (std::sqrt(v_hat) + 1e-8);
    }
  }
  const auto state = corrections.state();
  const auto values = state.at("pose_refine/values");
  for (int k = 0; k < 51; ++k) CHECK(values[2][k].item<double>() == Approx(x[k]).epsilon(1e-12));
  CHECK(values[0].abs().max().item<double>() == 0.0);
  CHECK(values[3].abs().max().item<double>() == 0.0);
  CHECK(state.at("pose_refine/steps")[2].item<int64_t>() == 5);
  CHECK(state.at("pose_refine/steps")[1].item<int64_t>() == 0);
  CHECK_THROWS_AS(corrections.step(4, torch::zeros({51})), handscs::Error);
}

TEST_CASE("pose refine: corrections apply as pose + d and trans + 0.1 m d, and gradients match finite "
          "differences through the avatar") {
  handscs::Avatar avatar = handscs_test::small_double_avatar();  // gates open: decoders see the pose
  auto gen = at::detail::createCPUGenerator(5);
  const auto pose = at::normal(0.0, 0.2, {48}, gen, torch::kFloat64);
  const auto trans = at::normal(0.0, 0.01, {3}, gen, torch::kFloat64);
  const int64_t n = avatar.gaussians().size();
  const auto w_means = at::rand({n, 3}, gen, torch::kFloat64);
  const auto w_cov = at::rand({n, 6}, gen, torch::kFloat64) * 1e4;  // covariances are ~1e-5 m^2
  const auto w_colors = at::rand({n, 3}, gen, torch::kFloat64);

  PoseCorrections corrections(3, refine_config(1e-3, 0.5));
  for (int t = 0; t < 3; ++t) corrections.step(1, at::randn({51}, gen, torch::kFloat64));
  auto objective = [&](const torch::Tensor& delta) {
    const auto s = avatar.pose(pose + delta.slice(0, 0, 48),
                               torch::zeros({10}, torch::kFloat64),
                               trans + 0.1 * delta.slice(0, 48, 51));
    return (s.posed.means * w_means).sum() + (s.posed.covariances * w_cov).sum() +
           (s.posed.colors * w_colors).sum() + 0.5 * delta.pow(2).sum();
  };
  const auto applied = corrections.apply(1, pose, trans, true);
  const auto d = corrections.state().at("pose_refine/values")[1];
  CHECK(torch::allclose(applied.pose, pose + d.slice(0, 0, 48), 0, 1e-15));
  CHECK(torch::allclose(applied.trans, trans + PoseCorrections::kTransUnit * d.slice(0, 48, 51), 0,
                        1e-15));
  const auto s = avatar.pose(applied.pose, torch::zeros({10}, torch::kFloat64), applied.trans);
  const auto loss = (s.posed.means * w_means).sum() + (s.posed.covariances * w_cov).sum() +
                    (s.posed.colors * w_colors).sum() + corrections.penalty(applied.delta);
  loss.backward();
  REQUIRE(applied.delta.grad().defined());
  const double h = 1e-6;
  // Global orientation, a finger joint of each of two fingers, and the translation.
  for (int64_t k : {0, 2, 7, 31, 47, 48, 50}) {
    auto plus = d.clone(), minus = d.clone();
    plus[k] += h;
    minus[k] -= h;
    double numeric;
    {
      torch::NoGradGuard no_grad;
      numeric = (objective(plus).item<double>() - objective(minus).item<double>()) / (2 * h);
    }
    const double analytic = applied.delta.grad()[k].item<double>();
    INFO("d[" << k << "]: analytic " << analytic << ", numeric " << numeric);
    CHECK(analytic == Approx(numeric).epsilon(1e-5).margin(1e-6));
  }
  // Not learned: a constant of the graph.
  CHECK_FALSE(corrections.apply(1, pose, trans, false).delta.requires_grad());
}

TEST_CASE("pose refine: a planted pose and translation error is recovered from renders alone") {
  handscs::set_threads(2);
  handscs::AvatarConfig config;
  config.decoder_hidden = 8;
  config.embedding_dim = 4;
  handscs::Avatar avatar(config, handscs::load_rig_source("builtin"));
  for (auto& p : avatar.gaussians().learnable()) p.second->set_requires_grad(false);
  for (auto& [group, params] : avatar.network_parameter_groups())
    for (auto& p : params) p.set_requires_grad(false);
  {
    // Colours that differ across the hand, so that a joint's rotation changes the image.
    torch::NoGradGuard no_grad;
    auto& g = avatar.gaussians();
    g.colors.copy_(0.5 + 4.0 * g.means);
  }
  auto gen = at::detail::createCPUGenerator(8);
  const auto true_pose = at::normal(0.0, 0.2, {48}, gen, torch::kFloat32);
  const auto true_trans = torch::zeros({3});
  const auto shape = torch::zeros({10});
  // Fit error of the realistic capture's size: ~3 degrees per component, 2 mm.
  const auto error_pose = at::normal(0.0, 3.0 * M_PI / 180, {48}, gen, torch::kFloat32);
  const auto error_trans = torch::tensor({0.002f, -0.002f, 0.0015f});
  const auto annotated_pose = true_pose + error_pose;
  const auto annotated_trans = true_trans + error_trans;
  const std::vector<handscs::Camera> cameras = {camera_at(0, 0.35), camera_at(0.25, 0.25),
                                                camera_at(-0.25, 0.25), camera_at(0.1, 0.33)};
  std::vector<torch::Tensor> targets;
  {
    torch::NoGradGuard no_grad;
    for (const auto& c : cameras)
      targets.push_back(avatar.forward(true_pose, shape, true_trans, c, {}).render.rgb);
  }
  const auto truth_means = avatar.pose(true_pose, shape, true_trans).posed.means.detach();
  auto mean_error_mm = [&](const torch::Tensor& pose, const torch::Tensor& trans) {
    torch::NoGradGuard no_grad;
    const auto means = avatar.pose(pose, shape, trans).posed.means;
    return (means - truth_means).norm(2, 1).mean().item<double>() * 1000;
  };
  PoseCorrections corrections(1, refine_config(2e-3, 1e-4));
  const double before = mean_error_mm(annotated_pose, annotated_trans);
  for (int step = 0; step < 200; ++step) {
    const auto c = corrections.apply(0, annotated_pose, annotated_trans, true);
    const size_t view = step % cameras.size();
    const auto out = avatar.forward(c.pose, shape, c.trans, cameras[view], {});
    const auto loss = (out.render.rgb - targets[view]).abs().mean() + corrections.penalty(c.delta);
    loss.backward();
    corrections.step(0, c.delta.grad());
  }
  const auto c = corrections.apply(0, annotated_pose, annotated_trans, false);
  const double after = mean_error_mm(c.pose, c.trans);
  INFO("mean Gaussian position error: " << before << " mm annotated, " << after << " mm refined");
  CHECK(before > 1.0);
  CHECK(after < 0.25 * before);  // measured: 9.1 mm -> 0.34 mm
  const auto summary = corrections.summary();
  CHECK(summary.at("pose_refine_mm") > 0.5);
}

TEST_CASE("pose refine: summary and CSV against loops, and checkpoint state is checked") {
  PoseCorrections corrections(5, refine_config(0.01, 0));
  auto gen = at::detail::createCPUGenerator(2);
  for (int row : {1, 3})
    for (int t = 0; t < 4; ++t) corrections.step(row, at::randn({51}, gen, torch::kFloat64));
  const auto values = corrections.state().at("pose_refine/values");
  double joints = 0, global = 0, trans = 0;
  for (int row : {1, 3}) {
    for (int j = 1; j < 16; ++j) {
      double a2 = 0;
      for (int k = 0; k < 3; ++k) a2 += std::pow(values[row][3 * j + k].item<double>(), 2);
      joints += a2;
    }
    for (int k = 0; k < 3; ++k) global += std::pow(values[row][k].item<double>(), 2);
    for (int k = 48; k < 51; ++k) trans += std::pow(0.1 * values[row][k].item<double>(), 2);
  }
  const auto summary = corrections.summary();
  CHECK(summary.at("pose_refine_deg") == Approx(std::sqrt(joints / 30) * 180 / M_PI));
  CHECK(summary.at("pose_refine_global_deg") == Approx(std::sqrt(global / 2) * 180 / M_PI));
  CHECK(summary.at("pose_refine_mm") == Approx(std::sqrt(trans / 2) * 1000));

  // CSV: a header and the two updated rows, with the translation in metres.
  std::istringstream csv(corrections.to_csv());
  std::string line;
  std::getline(csv, line);
  CHECK(line.rfind("pose_index,steps,joint_rms_deg,global_deg,trans_mm,pose_0,", 0) == 0);
  std::vector<std::string> rows;
  while (std::getline(csv, line)) rows.push_back(line);
  REQUIRE(rows.size() == 2);
  CHECK(rows[1].rfind("3,4,", 0) == 0);
  const double last = std::stod(rows[1].substr(rows[1].rfind(',') + 1));
  CHECK(last == Approx(0.1 * values[3][50].item<double>()).epsilon(1e-6));

  // Round trip, and state of another capture (another pose count) refused with the source named.
  PoseCorrections copy(5, refine_config(0.01, 0));
  copy.load_state(corrections.state(), "ckpt");
  CHECK(torch::equal(copy.state().at("pose_refine/values"), values));
  PoseCorrections other(6, refine_config(0.01, 0));
  CHECK_THROWS_WITH(other.load_state(corrections.state(), "run/step_3.ckpt"),
                    Catch::Contains("run/step_3.ckpt") && Catch::Contains("6 poses"));
  auto partial = corrections.state();
  partial.erase("pose_refine/exp_avg_sq");
  CHECK_THROWS_WITH(copy.load_state(partial, "ckpt"), Catch::Contains("pose_refine/exp_avg_sq"));
}

TEST_CASE("pose refine: the trainer refines training poses only and resumes them exactly") {
  handscs::set_threads(1);
  auto config = handscs_test::tiny_run_config();
  config.train.iterations = 16;
  config.train.checkpoint_every = 8;
  config.train.pose_refine.enabled = true;
  config.train.pose_refine.start = 4;
  const auto straight_dir = handscs_test::fresh_dir("refine_straight");
  std::vector<double> straight;
  std::set<int> held_out;
  {
    handscs::Trainer t(config, straight_dir);
    for (const auto& f : t.capture().test()) held_out.insert(f.pose_index);
    while (t.iteration() < 16) straight.push_back(t.step().loss);
    t.run();  // at the last step already: writes the final checkpoint and pose_refine.csv
  }
  REQUIRE_FALSE(held_out.empty());
  std::ifstream csv(straight_dir + "/pose_refine.csv");
  REQUIRE(csv.good());
  std::string line;
  std::getline(csv, line);
  int rows = 0;
  double largest = 0;
  while (std::getline(csv, line)) {
    ++rows;
    const int pose_index = std::stoi(line.substr(0, line.find(',')));
    CHECK(held_out.count(pose_index) == 0);
    std::istringstream fields(line);
    std::string field;
    for (int k = 0; k < 3; ++k) std::getline(fields, field, ',');
    largest = std::max(largest, std::stod(field));  // joint_rms_deg
  }
  CHECK(rows > 0);
  CHECK(largest > 0);

  const auto resumed_dir = handscs_test::fresh_dir("refine_resumed");
  std::vector<double> resumed;
  {
    handscs::Trainer t(config, resumed_dir);
    while (t.iteration() < 8) resumed.push_back(t.step().loss);
    t.save_checkpoint();
  }
  {
    handscs::Trainer t(config, resumed_dir);
    REQUIRE(t.resume());
    while (t.iteration() < 16) resumed.push_back(t.step().loss);
  }
  REQUIRE(resumed.size() == straight.size());
  for (size_t i = 0; i < straight.size(); ++i) {
    INFO("step " << i + 1);
    CHECK(resumed[i] == Approx(straight[i]).epsilon(1e-5));
  }
}
