// Per-camera colour transforms (train.camera_color, train/camera_color.h): the image-space form
// against compositing transformed colours, its gradient against central differences in double,
// the projection (mean at the identity, runaways clamped and named), learned transforms against
// the known transforms of synthetic cameras, a camera whose images are all dark, resume, and `off`
// training as the path that never builds the transforms.
#include "catch_torch.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <map>

#include "captured_warnings.h"
#include "checkpoint_compare.h"
#include "core/threads.h"
#include "gained_capture.h"
#include "train/adam.h"
#include "tiny_capture.h"
#include "run/checkpoint.h"
#include "train/camera_color.h"
#include "train/trainer.h"

using handscs_test::CapturedWarnings;
using handscs_test::fresh_dir;
using handscs_test::tiny_run_config;
using Mode = handscs::TrainConfig::CameraColor;

namespace {

// Trains `config` in `dir` to its iterations; returns the losses of every step.
std::vector<double> train_losses(const handscs::RunConfig& config, const std::string& dir) {
  handscs::Trainer trainer(config, dir);
  std::vector<double> losses;
  while (trainer.iteration() < config.train.iterations) {
    const auto r = trainer.step();
    REQUIRE_FALSE(r.skipped);
    losses.push_back(r.loss);
  }
  trainer.save_checkpoint();
  return losses;
}

// [C, 3, 4] transforms of the latest checkpoint of `dir`, by camera id.
std::map<std::string, torch::Tensor> learned_transforms(const std::string& dir) {
  const auto checkpoint = handscs::load_checkpoint(handscs::latest_checkpoint(dir));
  return handscs::CameraColorTable::from_checkpoint(checkpoint, dir).matrices;
}

}  // namespace

TEST_CASE("camera colour: the image-space transform equals compositing transformed colours") {
  // Two Gaussians over one pixel, front to back (opacities a1, a2, colours c1, c2) on a
  // background: the render is a1 c1 + (1 - a1) a2 c2 + (1 - a1)(1 - a2) bg, alpha 1 - (1 - a1)(1 -
  // a2). Transforming the render must equal rendering the transformed colours A c + b.
  torch::manual_seed(3);
  const auto opts = torch::TensorOptions().dtype(torch::kFloat64);
  const auto c1 = torch::rand({5, 7, 3}, opts), c2 = torch::rand({5, 7, 3}, opts);
  const auto a1 = torch::rand({5, 7, 1}, opts), a2 = torch::rand({5, 7, 1}, opts);
  const std::array<float, 3> background{0.25f, 0.5f, 1.0f};
  const auto bg = torch::tensor({0.25, 0.5, 1.0}, opts);
  auto composite = [&](const torch::Tensor& x1, const torch::Tensor& x2) {
    return a1 * x1 + (1 - a1) * a2 * x2 + (1 - a1) * (1 - a2) * bg;
  };
  const auto alpha = (1 - (1 - a1) * (1 - a2)).squeeze(2);
  for (const Mode mode : {Mode::gain, Mode::affine}) {
    const auto params = 0.2 * torch::randn({1, handscs::camera_color_width(mode)}, opts);
    const auto m = handscs::camera_color_matrices(mode, params)[0];
    auto transformed = [&](const torch::Tensor& c) {
      return torch::matmul(c, m.slice(1, 0, 3).transpose(0, 1)) + m.select(1, 3);
    };
    const auto expected = composite(transformed(c1), transformed(c2));
    const auto got = handscs::apply_color_transform(composite(c1, c2), alpha, background, m);
    CHECK((got - expected).abs().max().item<double>() < 1e-14);
    if (mode == Mode::gain) {  // gain: A diagonal, 1 + the first three parameters
      CHECK(m[0][0].item<double>() == Approx(1 + params[0][0].item<double>()).epsilon(1e-15));
      CHECK(m[0][1].item<double>() == 0.0);
      CHECK(m[2][3].item<double>() == params[0][5].item<double>());
    }
  }
}

TEST_CASE("camera colour: the transform's gradient matches central differences in double") {
  torch::manual_seed(5);
  const auto opts = torch::TensorOptions().dtype(torch::kFloat64);
  const std::array<float, 3> background{0.1f, 0.7f, 0.3f};
  for (const Mode mode : {Mode::gain, Mode::affine}) {
    INFO(handscs::camera_color_name(mode));
    auto rgb = torch::rand({4, 3, 3}, opts).requires_grad_(true);
    auto alpha = torch::rand({4, 3}, opts).requires_grad_(true);
    auto params = (0.3 * torch::randn({1, handscs::camera_color_width(mode)}, opts)).requires_grad_(true);
    const auto weights = torch::randn({4, 3, 3}, opts);
    auto loss = [&] {
      return (handscs::apply_color_transform(rgb, alpha, background,
                                             handscs::camera_color_matrices(mode, params)[0]) *
              weights)
          .sum();
    };
    loss().backward();
    for (torch::Tensor* x : {&rgb, &alpha, &params}) {
      const auto analytic = x->grad().clone().reshape(-1);
      auto numeric = torch::zeros_like(analytic);
      const double h = 1e-6;
      torch::NoGradGuard no_grad;
      auto flat = x->view(-1);
      for (int64_t i = 0; i < flat.numel(); ++i) {
        const double keep = flat[i].item<double>();
        flat[i] = keep + h;
        const double up = loss().item<double>();
        flat[i] = keep - h;
        const double down = loss().item<double>();
        flat[i] = keep;
        numeric[i] = (up - down) / (2 * h);
      }
      // The loss is linear or bilinear in each input: central differences are exact up to the
      // rounding of the sums (~1e-16 / h).
      CHECK((analytic - numeric).abs().max().item<double>() < 1e-8);
    }
  }
}

TEST_CASE("camera colour: the projection keeps the mean at the identity and clamps runaways") {
  CapturedWarnings warnings;
  handscs::CameraColors colors(Mode::gain, {"400001", "400002", "400003", "400004"});
  {
    torch::NoGradGuard no_grad;
    colors.parameters().copy_(torch::tensor({{0.1, 0.0, 0.0, 0.0, 0.0, 0.0},
                                             {-0.9, 0.0, 0.0, 0.0, 0.0, 0.0},  // gain 0.1
                                             {0.3, 0.0, 0.0, 0.0, 0.0, 0.5},   // bias 0.5
                                             {0.0, 0.0, 0.0, 0.0, 0.0, 0.0}}));
  }
  colors.project(/*warn=*/true);
  const auto p = colors.parameters().detach();
  // Clamped to gain 0.5 and bias 0.25, then the mean (0.1 - 0.5 + 0.3 + 0) / 4 = -0.025 and
  // 0.25 / 4 subtracted.
  CHECK(p[1][0].item<double>() == Approx(-0.5 + 0.025));
  CHECK(p[0][0].item<double>() == Approx(0.1 + 0.025));
  CHECK(p[2][5].item<double>() == Approx(0.25 - 0.0625));
  CHECK(p.mean(0).abs().max().item<double>() < 1e-7);
  const std::string text = warnings.text();
  CHECK(text.find("camera 400002: its colour transform runs away (gain 0.100 outside [0.5") !=
        std::string::npos);
  CHECK(text.find("camera 400003: its colour transform runs away (bias 0.500") != std::string::npos);
  CHECK(text.find("camera 400001") == std::string::npos);
}

TEST_CASE("camera colour: learned transforms recover the known transforms of each camera") {
  // Four cameras record random renders (colours and coverage, so a gain, a cross term and a bias
  // are told apart) through known transforms whose mean is the identity; the transforms learn as
  // training learns them (Adam, the L1 of the RGB loss, the penalty at its default weight, the
  // projection after every step, one camera per step) and must find them.
  torch::manual_seed(11);
  const std::vector<std::string> ids = {"400002", "400004", "400006", "400008"};
  const std::array<float, 3> background{0, 0, 0};
  for (const Mode mode : {Mode::gain, Mode::affine}) {
    INFO(handscs::camera_color_name(mode));
    const int64_t width = handscs::camera_color_width(mode);
    auto truth = 0.1 * torch::randn({4, width});
    truth -= truth.mean(0, /*keepdim=*/true);  // the mean transform is the identity
    const auto true_matrices = handscs::camera_color_matrices(mode, truth);
    std::vector<torch::Tensor> rgb, alpha, target;
    for (int k = 0; k < 4; ++k) {
      alpha.push_back(torch::rand({24, 16}));
      rgb.push_back(0.1 + 0.8 * torch::rand({24, 16, 3}) * alpha.back().unsqueeze(2));
      target.push_back(handscs::apply_color_transform(rgb.back(), alpha.back(), background,
                                                      true_matrices[k]));
    }
    handscs::CameraColors colors(mode, ids);
    handscs::Adam adam;
    const int64_t steps = 2000;
    // 1e-2 falling to 1e-4: fast at first, then still (L1's gradient keeps its size at the
    // optimum, so Adam's steps end at the learning rate's scale).
    adam.add_group("camera_color", {&colors.parameters()}, 1e-2, 1e-4, false);
    for (int64_t step = 0; step < steps; ++step) {
      const int64_t k = step % 4;
      const auto image = handscs::apply_color_transform(rgb[k], alpha[k], background, colors.matrix(k));
      ((image - target[k]).abs().mean() + colors.penalty(1e-3)).backward();
      adam.step(step, steps);
      colors.project(/*warn=*/true);
      adam.zero_grad();
    }
    const double error = (colors.parameters().detach() - truth).abs().max().item<double>();
    INFO("largest parameter error " << error);
    // 2e-3: the penalty's pull (1e-3 x 2 x 0.2 against an L1 gradient of ~0.1 per unit of
    // parameter) and Adam's last steps (1e-4 each) are both below 1e-3.
    CHECK(error < 2e-3);
  }
}

TEST_CASE("camera colour: a camera whose images are all dark is held at the range, named") {
  CapturedWarnings warnings;
  handscs::set_threads(2);
  // The last camera's images are black: its transform is pushed down for as long as the render
  // shows anything, its bias past the range's -0.25 first (the gain towards 0.5 after).
  const auto root = handscs_test::gained_tiny_capture(
      "dark_capture", {{1, 1, 1}, {1, 1, 1}, {1, 1, 1}, {0, 0, 0}});
  auto config = tiny_run_config();
  config.data.root = root;
  config.data.mask_refine.enabled = false;  // the dark camera keeps its hand masks
  config.data.skip_black_images = false;    // ... and its images
  config.train.iterations = 60;
  config.train.checkpoint_every = 60;
  config.train.densify.enabled = false;
  config.train.camera_color = Mode::gain;
  config.train.lr.camera_color = 5e-2;  // at 2e-2 the bias reaches -0.25 after ~150 steps
  const auto dir = fresh_dir("camera_color_dark");
  const auto losses = train_losses(config, dir);
  for (double loss : losses) REQUIRE(std::isfinite(loss));
  const auto ids = handscs_test::capture_camera_ids(root);
  const auto learned = learned_transforms(dir);
  const std::string text = warnings.text();
  INFO(text);
  CHECK(text.find("camera " + ids.back() + ": its colour transform runs away (") != std::string::npos);
  for (const auto& id : {ids[0], ids[1], ids[2]}) CHECK(text.find("camera " + id + ":") == std::string::npos);
  for (const auto& [id, m] : learned) {
    INFO(id);
    // Held: clamped (gain 0.5, bias -0.25) before the mean (at most a quarter of the range's
    // width) is subtracted.
    for (int c = 0; c < 3; ++c) {
      CHECK(m[c][c].item<double>() >= 0.5 - 1.5 / 4 - 1e-6);
      CHECK(m[c][3].item<double>() >= -0.25 - 0.5 / 4 - 1e-6);
    }
    CHECK(torch::isfinite(m).all().item<bool>());
  }
}

TEST_CASE("camera colour: resume keeps the transforms; an older checkpoint starts at the identity") {
  handscs::set_threads(1);
  auto config = tiny_run_config();
  config.train.iterations = 8;
  config.train.checkpoint_every = 4;
  config.train.densify.enabled = false;
  config.train.camera_color = Mode::affine;
  config.train.lr.camera_color = 1e-2;
  const auto straight_dir = fresh_dir("color_straight"), resumed_dir = fresh_dir("color_resumed");
  const auto straight = train_losses(config, straight_dir);
  std::vector<double> resumed;
  {
    // Stopped after 4 of the 8 steps (the schedules run over all 8).
    handscs::Trainer trainer(config, resumed_dir);
    while (trainer.iteration() < 4) resumed.push_back(trainer.step().loss);
    trainer.save_checkpoint();
  }
  {
    handscs::Trainer trainer(config, resumed_dir);
    REQUIRE(trainer.resume());
    REQUIRE(trainer.camera_colors() != nullptr);
    CHECK(trainer.camera_colors()->parameters().abs().sum().item<double>() > 0);
    while (trainer.iteration() < config.train.iterations) resumed.push_back(trainer.step().loss);
    trainer.save_checkpoint();
  }
  REQUIRE(resumed.size() == straight.size());
  for (size_t k = 0; k < straight.size(); ++k) CHECK(resumed[k] == straight[k]);
  const auto a = handscs::load_checkpoint(handscs::latest_checkpoint(straight_dir));
  const auto b = handscs::load_checkpoint(handscs::latest_checkpoint(resumed_dir));
  CHECK(torch::equal(a.tensors.at("camera_color/params"), b.tensors.at("camera_color/params")));
  CHECK(torch::equal(a.tensors.at("adam/camera_color/0/v"), b.tensors.at("adam/camera_color/0/v")));

  // A run trained with camera_color off resumes with gain: the transforms start at the identity.
  auto off = config;
  off.train.camera_color = Mode::off;
  off.train.iterations = 4;
  const auto old_dir = fresh_dir("color_from_off");
  train_losses(off, old_dir);
  auto on = config;
  on.train.camera_color = Mode::gain;
  handscs::Trainer trainer(on, old_dir);
  REQUIRE(trainer.resume());
  CHECK(trainer.camera_colors()->parameters().abs().sum().item<double>() == 0);
  CHECK(std::isfinite(trainer.step().loss));
  CHECK(trainer.camera_colors()->parameters().abs().sum().item<double>() > 0);
}

TEST_CASE("camera colour: off builds no transforms and trains as the path without them") {
  // Off is the path that never constructs the transforms: no optimiser group, no checkpoint
  // tensors, no camera_color.csv. A run with transforms that cannot move (learning rate 0, no
  // penalty) renders through the identity, which changes the images only by rounding (the
  // background's share is subtracted and added back): its parameters stay within float rounding
  // of the off run's.
  handscs::set_threads(1);
  auto config = tiny_run_config();
  config.train.iterations = 6;
  config.train.checkpoint_every = 6;
  config.train.densify.enabled = false;
  config.train.background = handscs::TrainConfig::Background::random;
  config.train.camera_color = Mode::off;
  const auto off_dir = fresh_dir("color_off"), still_dir = fresh_dir("color_still");
  const auto off = train_losses(config, off_dir);
  auto still = config;
  still.train.camera_color = Mode::affine;
  still.train.lr.camera_color = 0;
  still.train.loss.camera_color = 0;
  const auto held = train_losses(still, still_dir);
  const auto a = handscs::load_checkpoint(handscs::latest_checkpoint(off_dir));
  const auto b = handscs::load_checkpoint(handscs::latest_checkpoint(still_dir));
  for (const auto& [name, tensor] : a.tensors) {
    INFO(name);
    CHECK(name.find("camera_color") == std::string::npos);
  }
  CHECK_FALSE(a.meta.contains("camera_color"));
  CHECK_FALSE(std::filesystem::exists(off_dir + "/camera_color.csv"));
  CHECK(b.tensors.at("camera_color/params").abs().max().item<double>() == 0);
  for (size_t k = 0; k < off.size(); ++k) CHECK(held[k] == Approx(off[k]).epsilon(1e-5));
  const auto difference = handscs_test::compare_checkpoints(a, b, 1.0, [](const std::string& name) {
    return name.rfind("gaussians/", 0) == 0 && name != "gaussians/rotations";
  });
  CHECK(difference.mismatch == "");
  INFO("largest relative difference " << difference.worst << " in " << difference.worst_name);
  CHECK(difference.worst < 1e-4);
  // Rotations: the Gaussians start isotropic, so their rotation gradient is zero up to rounding,
  // and Adam turns a rounding-sized gradient into a step of up to the learning rate in either
  // direction. The two runs' rotations may then differ element by element by at most two such
  // steps per iteration, while as a whole they stay within rounding (relative L2).
  const auto rot_off = a.tensors.at("gaussians/rotations").to(torch::kFloat64);
  const auto rot_still = b.tensors.at("gaussians/rotations").to(torch::kFloat64);
  const double adam_bound = 2.0 * config.train.lr.rotations * config.train.iterations;
  CHECK((rot_still - rot_off).abs().max().item<double>() <= adam_bound);
  CHECK(((rot_still - rot_off).norm() / rot_off.norm()).item<double>() < 1e-4);
}
