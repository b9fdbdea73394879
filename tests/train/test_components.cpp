// The trainer's components and the state they serialise themselves: the checkpoint's sections
// keep the names older checkpoints use (so they still resume), the densifier's and Adam's own
// save/load round trips, and Adam's refusal of state that is missing or does not fit.
#include "test_support.h"
#include "catch_torch.h"

#include <set>
#include <string>

#include "run/checkpoint.h"
#include "tiny_capture.h"
#include "train/adam.h"
#include "train/densify.h"
#include "train/trainer.h"

using handscs_test::fresh_dir;

namespace {

// The names a checkpoint holds under the components' prefixes (the avatar's are tested with it).
std::set<std::string> component_tensor_names(const handscs::Checkpoint& checkpoint) {
  const char* prefixes[] = {"adam/", "consistency/", "pose_refine/", "camera_color/", "densify/"};
  std::set<std::string> names;
  for (const auto& [name, tensor] : checkpoint.tensors)
    for (const char* prefix : prefixes)
      if (name.rfind(prefix, 0) == 0) names.insert(name);
  return names;
}

}  // namespace

TEST_CASE("components: a checkpoint keeps the section names of the format older checkpoints use") {
  auto config = handscs_test::tiny_run_config();
  config.train.batch_size = 2;  // two inter-pose chains: consistency/ and consistency/view1/
  config.train.cull.enabled = true;
  config.train.pose_refine.enabled = true;
  config.train.pose_refine.start = 0;
  config.train.camera_color = handscs::TrainConfig::CameraColor::gain;
  config.train.densify.enabled = true;
  const std::string dir = fresh_dir("components_names");
  handscs::Trainer trainer(config, dir);
  trainer.step();
  trainer.step();
  const auto checkpoint = handscs::load_checkpoint(trainer.save_checkpoint());

  // The format written before the trainer was split into components, listed by hand.
  std::set<std::string> expected = {"pose_refine/values", "pose_refine/exp_avg",
                                    "pose_refine/exp_avg_sq", "pose_refine/steps",
                                    "camera_color/params", "densify/grad_sum", "densify/count"};
  for (const std::string chain : {"consistency/", "consistency/view1/"})
    for (const char* field : {"descriptor", "attributes", "pose_feature", "decoded"})
      expected.insert(chain + field);
  const char* avatar_groups[] = {"means", "log_scales", "rotations", "colors", "opacity"};
  for (const char* group : avatar_groups)
    for (const char* moment : {"m", "v"}) expected.insert(std::string("adam/") + group + "/0/" + moment);
  expected.insert("adam/embeddings/0/m");
  expected.insert("adam/embeddings/0/v");
  expected.insert("adam/embeddings/1/m");
  expected.insert("adam/embeddings/1/v");
  expected.insert("adam/camera_color/0/m");
  expected.insert("adam/camera_color/0/v");

  const auto names = component_tensor_names(checkpoint);
  // The networks' groups are the model's (their names and counts come from the decoders): every
  // other name must be one of the list.
  for (const std::string& name : expected) {
    INFO(name);
    CHECK(names.count(name) == 1);
  }
  for (const std::string& name : names) {
    if (expected.count(name)) continue;
    INFO(name);
    CHECK(name.rfind("adam/", 0) == 0);  // a network group's moments
    CHECK((name.substr(name.size() - 2) == "/m" || name.substr(name.size() - 2) == "/v"));
  }
  CHECK(checkpoint.meta.contains("camera_color"));
}

TEST_CASE("components: the densifier's statistics round-trip through a checkpoint") {
  handscs::DensifyConfig config;
  handscs::Densifier densifier(config);
  handscs::Densifier::ViewStatistics statistics;
  statistics.grad_norm = torch::tensor({0.5f, 0.f, 2.f});
  statistics.visible = torch::tensor({1.f, 0.f, 1.f});
  densifier.add(statistics);
  densifier.add(statistics);
  handscs::Checkpoint saved;
  densifier.save(saved);
  CHECK(torch::equal(saved.tensors.at("densify/grad_sum"), torch::tensor({1.f, 0.f, 4.f})));
  CHECK(torch::equal(saved.tensors.at("densify/count"), torch::tensor({2.f, 0.f, 2.f})));

  handscs::Densifier restored(config);
  restored.load(saved);
  handscs::Checkpoint again;
  restored.save(again);
  CHECK(torch::equal(again.tensors.at("densify/grad_sum"), saved.tensors.at("densify/grad_sum")));
  CHECK(torch::equal(again.tensors.at("densify/count"), saved.tensors.at("densify/count")));

  // A checkpoint without statistics (densification off when it was written) starts them afresh.
  handscs::Densifier empty(config);
  empty.load(handscs::Checkpoint{});
  handscs::Checkpoint none;
  empty.save(none);
  CHECK(none.tensors.empty());
}

TEST_CASE("components: Adam's moments round-trip, and missing or misfit state is refused by name") {
  auto a = torch::randn({4, 3});
  auto b = torch::randn({2});
  a.mutable_grad() = torch::randn({4, 3});
  b.mutable_grad() = torch::randn({2});
  handscs::Adam adam;
  adam.add_group("first", {&a}, 1e-2, 1e-2, true);
  adam.add_group("second", {&b}, 1e-2, 1e-2, false);
  adam.step(0, 10);
  handscs::Checkpoint saved;
  adam.save(saved);
  CHECK(saved.tensors.size() == 4);

  handscs::Adam restored;
  restored.add_group("first", {&a}, 1e-2, 1e-2, true);
  restored.add_group("second", {&b}, 1e-2, 1e-2, false);
  restored.load(saved, "ckpt", {});
  for (size_t g = 0; g < 2; ++g) {
    CHECK(torch::equal(restored.groups()[g].exp_avg[0], adam.groups()[g].exp_avg[0]));
    CHECK(torch::equal(restored.groups()[g].exp_avg_sq[0], adam.groups()[g].exp_avg_sq[0]));
  }

  handscs::Checkpoint missing = saved;
  missing.tensors.erase("adam/second/0/m");
  handscs::Adam strict;
  strict.add_group("first", {&a}, 1e-2, 1e-2, true);
  strict.add_group("second", {&b}, 1e-2, 1e-2, false);
  CHECK_THROWS_WITH(strict.load(missing, "ckpt", {}),
                    Catch::Contains("ckpt: checkpoint lacks optimiser state adam/second/0"));
  // A group the caller starts afresh (a component whose state the checkpoint lacks) is skipped.
  strict.load(missing, "ckpt", {"second"});
  CHECK(strict.groups()[1].exp_avg[0].abs().sum().item<double>() == 0);

  auto wider = torch::zeros({5, 3});
  handscs::Adam misfit;
  misfit.add_group("first", {&wider}, 1e-2, 1e-2, true);
  misfit.add_group("second", {&b}, 1e-2, 1e-2, false);
  CHECK_THROWS_WITH(misfit.load(saved, "ckpt", {}),
                    Catch::Contains("optimiser state adam/first/0 does not match"));
}
