// train.cull in the trainer: with nothing to cull it trains bit for bit as without it; with a cull
// it decodes a share of the Gaussians, logs that share, keeps L_con and L_reg finite, stores which
// Gaussians the inter-pose chain decoded, and resumes from it; densification sees the skipped
// Gaussians wherever the exact render would have.
#include "catch_torch.h"

#include <cmath>
#include <functional>

#include "checkpoint_compare.h"
#include "core/threads.h"
#include "tiny_capture.h"
#include "run/checkpoint.h"
#include "train/trainer.h"

using handscs_test::fresh_dir;
using handscs_test::tiny_run_config;

namespace {

// Trains `plain` and `culled` for their iterations in fresh folders (on_step sees each step's
// result and config) and returns their final checkpoints.
std::pair<handscs::Checkpoint, handscs::Checkpoint> train_plain_and_culled(
    const handscs::RunConfig& plain, const handscs::RunConfig& culled, const std::string& name,
    const std::function<void(const handscs::StepResult&, const handscs::RunConfig&)>& on_step = {}) {
  const auto plain_dir = fresh_dir(name + "_plain"), culled_dir = fresh_dir(name + "_culled");
  for (const auto& [c, dir] : {std::pair{plain, plain_dir}, std::pair{culled, culled_dir}}) {
    handscs::Trainer t(c, dir);
    while (t.iteration() < c.train.iterations) {
      const auto r = t.step();
      if (on_step) on_step(r, c);
    }
    t.save_checkpoint();
  }
  return {handscs::load_checkpoint(handscs::latest_checkpoint(plain_dir)),
          handscs::load_checkpoint(handscs::latest_checkpoint(culled_dir))};
}

}  // namespace

TEST_CASE("cull: a cull that keeps every Gaussian trains exactly as no cull") {
  handscs::set_threads(1);
  auto config = tiny_run_config();
  config.train.iterations = 4;
  config.train.log_every = 1;
  auto culled = config;
  culled.train.cull.enabled = true;
  culled.train.cull.max_cos = 1.0;  // every cosine is at most 1
  const auto [a, b] = train_plain_and_culled(config, culled, "cull_keep_all",
                                             [](const handscs::StepResult& r, const handscs::RunConfig& c) {
                                               CHECK(r.diagnostics.count("decoded_fraction") ==
                                                     (c.train.cull.enabled ? 1u : 0u));
                                               if (c.train.cull.enabled)
                                                 CHECK(r.diagnostics.at("decoded_fraction") == 1.0);
                                             });
  const auto difference = handscs_test::compare_checkpoints(a, b, 1e-30);
  CHECK(difference.mismatch == "");
  INFO("largest relative difference " << difference.worst << " in " << difference.worst_name);
  CHECK(difference.worst == 0);
  CHECK(b.tensors.count("consistency/decoded") == 0);  // nothing culled: no mask stored
  handscs::set_threads(2);
}

TEST_CASE("cull: training decodes a share of the Gaussians, logs it and resumes with the chain's mask") {
  handscs::set_threads(1);  // the resumed step is compared with the uninterrupted one
  auto config = tiny_run_config();
  config.train.iterations = 6;
  config.train.log_every = 1;
  config.train.cull.enabled = true;
  config.train.consistency.min_weight = 0;  // L_con on every pair of steps, however different
  const auto dir = fresh_dir("cull_train");
  int64_t gaussians = 0;
  handscs::StepResult continued;
  {
    handscs::Trainer t(config, dir);
    bool consistency_seen = false;
    while (t.iteration() < 4) {
      const auto r = t.step();
      REQUIRE(r.diagnostics.count("decoded_fraction") == 1);
      const double share = r.diagnostics.at("decoded_fraction");
      INFO("step " << t.iteration() << " decodes " << share);
      CHECK(share > 0.2);
      CHECK(share < 1.0);  // a hand seen from one camera has a back
      CHECK(std::isfinite(r.loss));
      CHECK(std::isfinite(r.terms.at("reg")));
      if (r.terms.count("consistency")) {
        consistency_seen = true;
        CHECK(std::isfinite(r.terms.at("consistency")));
      }
    }
    CHECK(consistency_seen);
    gaussians = t.avatar().gaussians().size();
    t.save_checkpoint();
    continued = t.step();  // the step the resumed run must repeat
  }
  const auto saved = handscs::load_checkpoint(handscs::latest_checkpoint(dir));
  REQUIRE(saved.tensors.count("consistency/decoded") == 1);
  const auto& mask = saved.tensors.at("consistency/decoded");
  CHECK(mask.scalar_type() == torch::kBool);
  CHECK(mask.numel() == gaussians);
  const int64_t decoded = mask.sum().item<int64_t>();
  CHECK(decoded > 0);
  CHECK(decoded < gaussians);
  handscs::Trainer resumed(config, dir);
  REQUIRE(resumed.resume());
  REQUIRE(resumed.iteration() == 4);
  const auto r = resumed.step();
  // The stored chain, mask included, pairs the resumed step as it paired the uninterrupted one (a
  // mask lost on resume would count the pairs of a third of the Gaussians more).
  REQUIRE(r.terms.count("consistency") == 1);
  REQUIRE(continued.terms.count("consistency") == 1);
  CHECK(r.terms.at("consistency") == Approx(continued.terms.at("consistency")).epsilon(1e-9));
  CHECK(r.loss == Approx(continued.loss).epsilon(1e-9));
  handscs::set_threads(2);
}

TEST_CASE("cull: densification counts a skipped Gaussian as seen wherever the exact render projects it") {
  // At the first step the decoder gates are 0: every offset is zero, so the exact render projects
  // each Gaussian from the same geometry the cull's count uses, and the counts agree exactly.
  handscs::set_threads(1);
  auto config = tiny_run_config();
  config.train.iterations = 1;
  config.train.densify.enabled = true;
  config.train.densify.start = 1000;  // statistics accumulate, nothing densifies
  auto culled = config;
  culled.train.cull.enabled = true;
  const auto [a, b] = train_plain_and_culled(config, culled, "cull_densify");
  const auto& count = b.tensors.at("densify/count");
  CHECK(torch::equal(count, a.tensors.at("densify/count")));
  CHECK(count.sum().item<double>() > 0.9 * count.numel());  // the crop sees nearly every Gaussian
  const auto& decoded = b.tensors.at("consistency/decoded");
  const int64_t skipped = count.numel() - decoded.sum().item<int64_t>();
  CHECK(skipped > 0);
  // The skipped rows: seen, no gradient.
  const auto& grad = b.tensors.at("densify/grad_sum");
  CHECK(grad.index({decoded.logical_not()}).abs().max().item<double>() == 0);
  handscs::set_threads(2);
}
