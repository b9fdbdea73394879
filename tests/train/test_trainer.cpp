// Training end to end on the tiny synthetic capture: the loss falls with no NaN, checkpoints resume
// to the same loss curve, NaN steps never reach the parameters and roll back, and damaged
// checkpoints are refused; train.keep_checkpoints decides how many checkpoints stay.
#include "catch_torch.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <string>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/threads.h"
#include "tiny_capture.h"
#include "run/checkpoint.h"
#include "train/trainer.h"

using handscs_test::fresh_dir;
using handscs_test::tiny_run_config;

TEST_CASE("trainer: 100 steps on tiny lower the loss, with no NaN, and write their outputs") {
  handscs::set_threads(2);
  auto config = tiny_run_config();
  const auto run = fresh_dir("train100");
  handscs::Trainer trainer(config, run);
  std::vector<double> losses;
  handscs::StepResult last;
  while (trainer.iteration() < config.train.iterations) {
    const auto r = trainer.step();
    last = r;
    REQUIRE_FALSE(r.skipped);
    REQUIRE(std::isfinite(r.loss));
    losses.push_back(r.loss);
  }
  auto mean = [&](size_t from, size_t to) {
    double s = 0;
    for (size_t i = from; i < to; ++i) s += losses[i];
    return s / (to - from);
  };
  INFO("mean loss of steps 1-10: " << mean(0, 10) << ", of steps 91-100: " << mean(90, 100));
  CHECK(mean(90, 100) < 0.7 * mean(0, 10));
  const auto path = trainer.save_checkpoint();
  CHECK(std::filesystem::exists(path));
  CHECK(std::filesystem::exists(run + "/config.json"));
  REQUIRE(std::filesystem::exists(run + "/metrics.csv"));
  // metrics.csv shows what the model uses: its header names the decoder gates and the mean offset
  // norms, and the last step has them all, finite, with the gates learned away from their initial 0.
  std::ifstream csv(run + "/metrics.csv");
  std::string header;
  std::getline(csv, header);
  for (const char* column : {"gate_geometry", "gate_appearance", "gate_fusion", "offset_dx",
                             "offset_dsigma", "offset_dc", "offset_dx_f", "offset_dsigma_f",
                             "offset_dc_f", "consistency"}) {
    INFO(column);
    CHECK(("," + header + ",").find("," + std::string(column) + ",") != std::string::npos);
    if (std::string(column) == "consistency") continue;  // a loss term, not a diagnostic
    REQUIRE(last.diagnostics.count(column) == 1);
    CHECK(std::isfinite(last.diagnostics.at(column)));
    if (std::string(column).rfind("gate_", 0) == 0) CHECK(last.diagnostics.at(column) != 0.0);
  }
}

TEST_CASE("trainer: resume continues to the same loss curve as an uninterrupted run") {
  handscs::set_threads(1);
  auto config = tiny_run_config();
  config.train.iterations = 12;
  config.train.densify.enabled = true;  // densifier state must round-trip too
  config.train.densify.start = 4;
  config.train.densify.interval = 4;
  config.train.densify.grad_threshold = 0;  // densify something every time
  config.train.densify.max_gaussians = 1800;
  config.train.background = handscs::TrainConfig::Background::random;
  const auto straight_dir = fresh_dir("straight");
  std::vector<double> straight;
  {
    handscs::Trainer t(config, straight_dir);
    while (t.iteration() < 12) straight.push_back(t.step().loss);
  }
  const auto resumed_dir = fresh_dir("resumed");
  std::vector<double> resumed;
  {
    handscs::Trainer t(config, resumed_dir);
    while (t.iteration() < 6) resumed.push_back(t.step().loss);
    t.save_checkpoint();
  }
  {
    handscs::Trainer t(config, resumed_dir);
    REQUIRE(t.resume());
    CHECK(t.iteration() == 6);
    while (t.iteration() < 12) resumed.push_back(t.step().loss);
  }
  REQUIRE(resumed.size() == straight.size());
  for (size_t i = 0; i < straight.size(); ++i) {
    INFO("step " << i + 1);
    CHECK(resumed[i] == straight[i]);  // identical, not approximately equal
  }
  handscs::set_threads(2);
}

TEST_CASE("trainer: NaN steps are skipped, then rolled back with a lower learning rate") {
  auto config = tiny_run_config();
  config.train.max_bad_steps = 3;
  config.train.rollback_lr_factor = 0.5;
  handscs::Trainer trainer(config, fresh_dir("nan"));
  for (int i = 0; i < 4; ++i) trainer.step();
  trainer.save_checkpoint();
  const auto good_means = trainer.avatar().gaussians().means.detach().clone();
  {
    torch::NoGradGuard no_grad;
    trainer.avatar().gaussians().means[0][0] = NAN;  // poisons the descriptor, decoders and L_reg
  }
  const auto before = trainer.avatar().gaussians().colors.detach().clone();
  auto r1 = trainer.step();
  CHECK(r1.skipped);
  CHECK(torch::equal(trainer.avatar().gaussians().colors.detach(), before));  // untouched
  trainer.step();
  auto r3 = trainer.step();
  CHECK(r3.skipped);
  CHECK(r3.rolled_back);
  CHECK(trainer.iteration() == 4);
  CHECK(torch::equal(trainer.avatar().gaussians().means.detach(), good_means));
  auto r4 = trainer.step();
  CHECK_FALSE(r4.skipped);
  CHECK(std::isfinite(r4.loss));
}

TEST_CASE("trainer: a run that fails its start checks leaves no empty checkpoints folder") {
  auto config = tiny_run_config();
  config.train.resolution_scale = 0.05;  // every image too small for the image losses
  const std::string dir = fresh_dir("early_failure");
  CHECK_THROWS_WITH(handscs::Trainer(config, dir), Catch::Contains("train.resolution_scale"));
  CHECK_FALSE(std::filesystem::exists(dir + "/checkpoints"));
}

TEST_CASE("checkpoint: truncated, corrupted and foreign files are refused with their path") {
  const auto dir = fresh_dir("ckpt");
  std::filesystem::create_directories(dir);
  handscs::Checkpoint ckpt;
  ckpt.meta["iteration"] = 7;
  ckpt.tensors["a"] = torch::arange(1000, torch::kFloat32);
  const auto path = dir + "/good.ckpt";
  handscs::save_checkpoint(path, ckpt);
  const auto back = handscs::load_checkpoint(path);
  CHECK(back.meta["iteration"] == 7);
  CHECK(torch::equal(back.tensors.at("a"), ckpt.tensors.at("a")));

  std::string bytes = handscs::read_file(path);
  {
    std::ofstream(dir + "/truncated.ckpt", std::ios::binary) << bytes.substr(0, bytes.size() / 2);
    CHECK_THROWS_WITH(handscs::load_checkpoint(dir + "/truncated.ckpt"),
                      dir + "/truncated.ckpt: not a complete HandSCS checkpoint (truncated or another format)");
  }
  {
    std::string flipped = bytes;
    flipped[bytes.size() / 2] ^= 0x40;
    std::ofstream(dir + "/flipped.ckpt", std::ios::binary) << flipped;
    CHECK_THROWS_WITH(handscs::load_checkpoint(dir + "/flipped.ckpt"),
                      dir + "/flipped.ckpt: checkpoint is corrupted (checksum mismatch)");
  }
  {
    std::ofstream(dir + "/foreign.ckpt") << "{\"not\": \"a checkpoint\"}";
    CHECK_THROWS_WITH(handscs::load_checkpoint(dir + "/foreign.ckpt"),
                      Catch::Contains("not a complete HandSCS checkpoint"));
  }
}

TEST_CASE("trainer: the k-d tree and the GEMM search give the same L_con") {
  // Both searches end by the distance in double (train/nearest_in_double.h), so the same seed gives
  // the same correspondences and, in one thread, the same consistency term to the last bit, step by
  // step. A float search alone settles near-ties by its rounding, which differs between CPUs' BLAS
  // kernels: that moved L_con by 5% within five steps on one machine.
  handscs::set_threads(1);
  std::vector<std::vector<double>> terms;
  using Search = handscs::ConsistencyConfig::Search;
  for (const auto& [search, name] : {std::pair{Search::exact, "exact"}, std::pair{Search::tree, "tree"}}) {
    auto config = tiny_run_config();
    config.train.consistency.search = search;
    config.train.consistency.min_weight = 0;  // every pair searched
    handscs::Trainer trainer(config, fresh_dir(std::string("search_") + name));
    terms.emplace_back();
    for (int i = 0; i < 6; ++i) {
      const auto r = trainer.step();
      if (r.terms.count("consistency")) terms.back().push_back(r.terms.at("consistency"));
    }
  }
  REQUIRE(terms[0].size() == 5);  // from the second step on
  REQUIRE(terms[1].size() == terms[0].size());
  for (size_t i = 0; i < terms[0].size(); ++i) CHECK(terms[1][i] == terms[0][i]);
  handscs::set_threads(2);
}

TEST_CASE("trainer: pose pairs less similar than train.consistency.min_weight skip L_con") {
  handscs::set_threads(1);
  const int steps = 10;
  // Every pair first: the weights of the seed's frame sequence (they depend on the poses alone).
  std::vector<double> weights;
  {
    auto config = tiny_run_config();
    config.train.consistency.min_weight = 0;
    handscs::Trainer trainer(config, fresh_dir("min_weight_all"));
    for (int i = 0; i < steps; ++i) {
      const auto r = trainer.step();
      CHECK(r.terms.count("consistency") == (i == 0 ? 0u : 1u));
      weights.push_back(r.consistency_weight);
    }
  }
  CHECK(weights[0] == -1);  // no previous step
  std::vector<double> sorted(weights.begin() + 1, weights.end());
  std::sort(sorted.begin(), sorted.end());
  const double threshold = sorted[sorted.size() / 2];  // about half the pairs skip
  REQUIRE(sorted.front() < threshold);
  auto config = tiny_run_config();
  config.train.consistency.min_weight = threshold;
  handscs::Trainer trainer(config, fresh_dir("min_weight_half"));
  for (int i = 0; i < steps; ++i) {
    const auto r = trainer.step();
    INFO("step " << i + 1 << ", weight " << weights[i]);
    CHECK(r.consistency_weight == Approx(weights[i]).margin(1e-12));
    CHECK(r.terms.count("consistency") == (i > 0 && weights[i] >= threshold ? 1u : 0u));
  }
  handscs::set_threads(2);
}

TEST_CASE("trainer: train.loss.lpips_every takes LPIPS on the steps whose number it divides") {
  auto config = tiny_run_config();
  config.eval.lpips.weights = handscs_test::kLpipsAlexWeights;
  config.train.loss.lpips_every = 3;
  handscs::Trainer trainer(config, fresh_dir("lpips_every"));
  for (int i = 0; i < 7; ++i) {
    const auto r = trainer.step();
    INFO("step " << r.iteration);
    CHECK(r.terms.count("lpips") == (r.iteration % 3 == 0 ? 1u : 0u));
    CHECK(r.terms.count("ssim") == 1u);
  }
}

TEST_CASE("trainer: train.keep_checkpoints keeps the newest N checkpoints, 0 keeps them all") {
  handscs::set_threads(1);
  for (const int64_t keep : {0, 1, 2}) {
    INFO("keep_checkpoints " << keep);
    auto config = tiny_run_config();
    config.train.keep_checkpoints = keep;
    const auto run = fresh_dir("keep" + std::to_string(keep));
    handscs::Trainer trainer(config, run);
    std::vector<std::string> saved;  // oldest first
    for (int k = 0; k < 3; ++k) {
      trainer.step();
      saved.push_back(trainer.save_checkpoint());
    }
    std::vector<std::string> expected(saved.rbegin(), saved.rend());  // newest first
    if (keep > 0) expected.resize(static_cast<size_t>(keep));
    CHECK(handscs::list_checkpoints(run) == expected);
  }
}
