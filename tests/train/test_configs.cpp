// The shipped configs: base.json equals the compiled-in defaults, docs/CONFIG.md documents every
// key, and every run config under configs/ loads and validates.
#include "catch_torch.h"
#include "captured_warnings.h"
#include "test_support.h"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "core/atomic_file.h"
#include "core/config.h"
#include "run/avatar_state_io.h"
#include "run/run_config.h"

namespace {
using handscs_test::kSource;
}

TEST_CASE("configs: base.json holds exactly the defaults") {
  handscs::RunConfig defaults;
  const auto base = handscs::load_json_file(kSource + "/configs/base.json");
  // Regenerate with: build/bin/handscs-train --print-defaults > configs/base.json
  CHECK(base == handscs::config_to_json(defaults));
}

TEST_CASE("configs: docs/CONFIG.md documents every key") {
  handscs::RunConfig defaults;
  const std::string doc = handscs::read_file(kSource + "/docs/CONFIG.md");
  // Regenerate the table with: build/bin/handscs-train --print-docs
  CHECK(doc.find(handscs::config_markdown(defaults)) != std::string::npos);
}

TEST_CASE("configs: every shipped config loads and validates") {
  int count = 0;
  for (const auto& entry : std::filesystem::recursive_directory_iterator(kSource + "/configs")) {
    if (entry.path().extension() != ".json") continue;
    // configs/sweeps/ holds handscs-bench sweep files (tests/sweep checks them), not run configs.
    if (entry.path().parent_path().filename() == "sweeps") continue;
    INFO(entry.path().string());
    handscs::RunConfig config;
    CHECK_NOTHROW(config = handscs::load_config<handscs::RunConfig>(entry.path().string(), {}));
    CHECK_NOTHROW(handscs::validate_run_config(config, entry.path().string()));
    ++count;
  }
  CHECK(count >= 2);
}

TEST_CASE("configs: the paper's InterHand2.6M protocol configs resolve to their capture and split") {
  struct Expected {
    const char* file;
    const char* split;
    int capture;
    const char* rule;
  };
  // Paper tables: novel pose on five subjects, novel view on the first three.
  const Expected expected[] = {
      {"test_capture0_novel_pose", "test", 0, "novel_pose"},
      {"test_capture1_novel_pose", "test", 1, "novel_pose"},
      {"val_capture0_novel_pose", "val", 0, "novel_pose"},
      {"train_capture5_novel_pose", "train", 5, "novel_pose"},
      {"train_capture6_novel_pose", "train", 6, "novel_pose"},
      {"test_capture0_novel_view", "test", 0, "novel_view"},
      {"test_capture1_novel_view", "test", 1, "novel_view"},
      {"val_capture0_novel_view", "val", 0, "novel_view"},
  };
  for (const auto& e : expected) {
    INFO(e.file);
    const std::string path = kSource + "/configs/interhand/" + e.file + ".json";
    const auto config = handscs::load_config<handscs::RunConfig>(path, {"data.root=/data/ih26m"});
    handscs::validate_run_config(config, path);
    CHECK(config.data.split == e.split);
    CHECK(config.data.capture == e.capture);
    CHECK(config.data.split_rule == handscs::choice_value(e.rule, handscs::CaptureConfig::split_rule_names()));
    CHECK(config.data.hand == handscs::CaptureConfig::Hands::right);
    CHECK(config.data.held_out_poses == 50);
    CHECK(config.data.test_cameras.empty());  // novel_view: 10 train / 15 test chosen by id
    CHECK(config.data.novel_view_train_views == 10);
    CHECK(config.data.novel_view_test_views == 15);
    CHECK_FALSE(config.data.include_interacting);
  }
}

TEST_CASE("configs: cross-section mismatches are errors naming both keys") {
  handscs::RunConfig config;
  config.model.rig = "builtin:left";
  CHECK_THROWS_WITH(handscs::validate_run_config(config, "x.json"),
                    Catch::StartsWith("x.json: data.rig (\"builtin\") and model.rig (\"builtin:left\")"));
  config = {};
  config.eval.background = {2, -1, 0.5};
  CHECK_THROWS_WITH(handscs::validate_run_config(config, "x.json"),
                    "x.json: eval.background: values must be in [0, 1] (got 2)");
  config = {};
  config.data.mask_refine.low = 150;
  config.data.mask_refine.high = 100;
  CHECK_THROWS_WITH(handscs::validate_run_config(config, "x.json"),
                    "x.json: data.mask_refine.low (150) must be below data.mask_refine.high (100), "
                    "or every mask would be empty");
  config.data.mask_refine.enabled = false;  // not refined: the bounds are unused
  CHECK_NOTHROW(handscs::validate_run_config(config, "x.json"));
}

TEST_CASE("configs: the old form with model.rig and model.flat_hand_mean still loads") {
  // config.json files and checkpoints (meta "config") written before data.rig served the model
  // carry model.rig and model.flat_hand_mean beside the data keys.
  handscs::RunConfig defaults;
  handscs::json old = handscs::config_to_json(defaults);
  old["data"]["rig"] = "builtin:left";
  old["data"]["hand"] = "left";
  old["data"]["flat_hand_mean"] = true;
  old["model"]["rig"] = "builtin:left";
  old["model"]["flat_hand_mean"] = true;
  handscs::RunConfig config;
  handscs::config_from_json(old, "old.json", config);
  CHECK(config.data.rig == "builtin:left");
  CHECK(config.model.rig == "builtin:left");
  CHECK(config.model.flat_hand_mean);
  CHECK(config.data.hand == handscs::CaptureConfig::Hands::left);
  CHECK_NOTHROW(handscs::validate_run_config(config, "old.json"));
  // Written back in the new form: one key each.
  const handscs::json written = handscs::config_to_json(config);
  CHECK_FALSE(written["model"].contains("rig"));
  CHECK_FALSE(written["model"].contains("flat_hand_mean"));
  CHECK(written["data"]["rig"] == "builtin:left");
  CHECK(written["data"]["hand"] == "left");

  // The same as a file, and as --set pairs the way the old README wrote them.
  const std::string path = handscs_test::scratch_file("handscs_test_old_config", "old.json", old.dump(2));
  CHECK_NOTHROW(config = handscs::load_config<handscs::RunConfig>(path, {}));
  CHECK(config.model.rig == "builtin:left");
  CHECK_NOTHROW(config = handscs::load_config<handscs::RunConfig>(
                    "", {"data.rig=builtin:left", "model.rig=builtin:left", "data.hand=left"}));
  CHECK(config.model.rig == "builtin:left");

  // Disagreeing, they are an error naming both keys.
  old["model"]["rig"] = "builtin";
  CHECK_THROWS_WITH(handscs::config_from_json(old, "old.json", config),
                    Catch::StartsWith("old.json: data.rig (\"builtin:left\") and model.rig (\"builtin\") must agree"));
  old["model"]["rig"] = "builtin:left";
  old["model"]["flat_hand_mean"] = false;
  CHECK_THROWS_WITH(handscs::config_from_json(old, "old.json", config),
                    Catch::StartsWith("old.json: data.flat_hand_mean (true) and model.flat_hand_mean (false) must agree"));
  CHECK_THROWS_WITH(handscs::load_config<handscs::RunConfig>("", {"model.rig=mano_right.json"}),
                    Catch::StartsWith("defaults + --set: data.rig (\"builtin\") and model.rig (\"mano_right.json\") must agree"));
  // A trained avatar's rig is its checkpoint's: data.rig serves the model, so it is no override.
  CHECK_THROWS_WITH(handscs::refuse_model_overrides({"data.rig=mano_right.json"}),
                    Catch::StartsWith("--set data.rig=mano_right.json: the rig is the checkpoint's"));
}

TEST_CASE("configs: a deprecated key warns once per file, and not at all from a checkpoint") {
  handscs::RunConfig defaults;
  handscs::json old = handscs::config_to_json(defaults);
  old["model"]["rig"] = "builtin";  // agrees with data.rig
  const std::string path =
      handscs_test::scratch_file("handscs_test_deprecated_once", "old_rig.json", old.dump(2));
  const auto count = [](const std::vector<std::string>& messages, const std::string& part) {
    return std::count_if(messages.begin(), messages.end(),
                         [&](const std::string& m) { return m.find(part) != std::string::npos; });
  };
  {
    // The file is read alone, then again merged with --set: one warning, naming the file.
    handscs_test::CapturedWarnings warnings;
    CHECK_NOTHROW(handscs::load_config<handscs::RunConfig>(path, {"train.iterations=10"}));
    const auto messages = warnings.messages();
    CHECK(count(messages, "model.rig is deprecated") == 1);
    CHECK(count(messages, path + ": model.rig is deprecated") == 1);
  }
  {
    // Given by --set alone, it is named as the overrides' (the file does not hold it).
    const std::string plain = handscs_test::scratch_file("handscs_test_deprecated_once", "plain.json",
                                                         handscs::config_to_json(defaults).dump(2));
    handscs_test::CapturedWarnings warnings;
    CHECK_NOTHROW(handscs::load_config<handscs::RunConfig>(plain, {"model.rig=builtin"}));
    CHECK(count(warnings.messages(), plain + " + --set: model.rig is deprecated") == 1);
  }
  {
    // A checkpoint's stored config, read twice as open_trained_avatar does: not the user's to edit.
    handscs_test::CapturedWarnings warnings;
    const std::string stored = "run/step_00000100.ckpt" + std::string(handscs::kStoredConfig);
    handscs::RunConfig config;
    CHECK_NOTHROW(handscs::config_from_json(old, stored, config));
    CHECK_NOTHROW(handscs::config_from_json(old, stored + handscs::kWithOverrides, config));
    CHECK(count(warnings.messages(), "model.rig") == 0);
  }
}

TEST_CASE("configs: every point of every sweep file applies to its run config") {
  // A sweep names its run config relative to itself and overrides keys for all points ("set") and
  // per point; a misspelt key or a value out of range would only show when that row's training
  // starts, hours into a sweep.
  int points = 0;
  for (const auto& entry : std::filesystem::directory_iterator(kSource + "/configs/sweeps")) {
    if (entry.path().extension() != ".json") continue;
    const auto sweep = handscs::load_json_file(entry.path().string());
    const std::string run_config =
        (entry.path().parent_path() / sweep.at("run_config").get<std::string>()).string();
    const auto common = sweep.value("set", std::vector<std::string>{});
    for (const auto& point : sweep.at("points")) {
      auto set = common;
      for (const auto& s : point.value("set", std::vector<std::string>{})) set.push_back(s);
      INFO(entry.path().filename().string() << ": " << point.at("name").get<std::string>());
      handscs::RunConfig config;
      CHECK_NOTHROW(config = handscs::load_config<handscs::RunConfig>(run_config, set));
      CHECK_NOTHROW(handscs::validate_run_config(config, run_config));
      ++points;
    }
  }
  CHECK(points > 100);
}
