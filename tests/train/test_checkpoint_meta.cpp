// Checkpoints are checked after their checksum (run/checkpoint_meta.h): edited metadata with its
// checksum recomputed is refused with the file and the field named, resume falls back past such a
// file and sets it aside instead of deleting the valid one it resumed from, a file named for
// another step than it holds is refused, and only regular files of a bounded size are read.
#include "catch_torch.h"

#include <sys/stat.h>

#include <filesystem>
#include <functional>
#include <limits>
#include <cmath>
#include <string>

#include "core/atomic_file.h"
#include "core/config.h"
#include "core/error.h"
#include "data/capture.h"
#include "data/capture_identity.h"
#include "synth/capture.h"
#include "synth/config.h"
#include "core/threads.h"
#include "run/checkpoint.h"
#include "run/checkpoint_meta.h"
#include "run/run_config.h"
#include "test_support.h"
#include "tiny_capture.h"
#include "train/trainer.h"

using handscs_test::fresh_dir;
using handscs_test::tiny_run_config;

namespace {

namespace fs = std::filesystem;

// A 4-step tiny run with checkpoints at steps 2 and 4.
handscs::RunConfig four_step_config() {
  auto config = tiny_run_config();
  config.train.iterations = 4;
  config.train.checkpoint_every = 2;
  config.train.densify.enabled = false;
  return config;
}

std::string train_four_steps(const std::string& dir) {
  handscs::Trainer trainer(four_step_config(), dir);
  while (trainer.iteration() < 4) {
    trainer.step();
    if (trainer.iteration() % 2 == 0) trainer.save_checkpoint();
  }
  return dir + "/checkpoints/";
}

std::string meta_error(const nlohmann::json& meta, const std::string& source) {
  return handscs_test::error_of([&] { handscs::check_checkpoint_meta(meta, source); });
}

}  // namespace

TEST_CASE("checkpoint meta: each field is checked for type and range, naming file and field") {
  handscs::set_threads(1);
  const auto dir = fresh_dir("meta_fields");
  const auto checkpoints = train_four_steps(dir);
  const std::string file = checkpoints + handscs::checkpoint_name(4);
  const auto good = handscs::load_checkpoint(file).meta;
  CHECK_NOTHROW(handscs::check_checkpoint_meta(good, file));

  auto edited = [&](const std::function<void(nlohmann::json&)>& edit) {
    nlohmann::json meta = good;
    edit(meta);
    return meta_error(meta, "X.ckpt");
  };
  CHECK(edited([](auto& m) { m["iteration"] = -5; }) ==
        "X.ckpt: checkpoint metadata 'iteration' is -5, outside [0, 4]");
  CHECK(edited([](auto& m) { m["iteration"] = 4000000000000000000LL; }) ==
        "X.ckpt: checkpoint metadata 'iteration' is 4000000000000000000, outside [0, 4]");
  CHECK(edited([](auto& m) { m["iteration"] = "7"; }) ==
        "X.ckpt: checkpoint metadata 'iteration' is \"7\", not an integer");
  CHECK(edited([](auto& m) { m["version"] = 99; }) ==
        "X.ckpt: checkpoint format version 99; this build reads 1");
  CHECK(edited([](auto& m) { m["adam_steps"] = -7; }) ==
        "X.ckpt: checkpoint metadata 'adam_steps' is -7, outside [0, 9223372036854775807]");
  CHECK(edited([](auto& m) { m.erase("config"); }) == "X.ckpt: checkpoint metadata lacks 'config'");
  CHECK(edited([](auto& m) { m["config"] = 3; }) ==
        "X.ckpt: checkpoint metadata 'config' is not a run config (no train.iterations)");
  CHECK(edited([](auto& m) { m["lr_scale"] = 0; }) ==
        "X.ckpt: checkpoint metadata 'lr_scale' is 0.000000, outside (0, 1]");
  CHECK(edited([](auto& m) { m["lr_scale"] = "nan"; }) ==
        "X.ckpt: checkpoint metadata 'lr_scale' is \"nan\", not a finite number");
  CHECK(edited([](auto& m) { m["running_psnr"] = nullptr; }) ==
        "X.ckpt: checkpoint metadata 'running_psnr' is null, not a finite number");
  CHECK(edited([](auto& m) { m["format"] = "other"; }) ==
        "X.ckpt: checkpoint metadata 'format' is \"other\", not \"handscs-checkpoint\" (not a "
        "HandSCS training checkpoint)");
  CHECK(edited([](auto& m) { m["capture_identity"]["calibration"] = "12"; }) ==
        "X.ckpt: checkpoint metadata capture_identity.calibration: expected 16 hex digits");
  CHECK(edited([](auto& m) { m["capture_identity"]["annotations"] = "0123456789abcdeX"; }) ==
        "X.ckpt: checkpoint metadata capture_identity.annotations: expected 16 hex digits, got "
        "\"0123456789abcdeX\"");
  CHECK(edited([](auto& m) { m["capture_identity"]["frames"] = -1; }) ==
        "X.ckpt: checkpoint metadata capture_identity.frames: expected a non-negative integer");
  CHECK(edited([](auto& m) { m["placement"] = 5; }) ==
        "X.ckpt: checkpoint metadata 'placement' is 5, not an object");
  // Counters the first checkpoints lacked may be absent, and so may the capture's identity and
  // the placement of its hands.
  CHECK(edited([](auto& m) { m.erase("rollbacks"); m.erase("elapsed_seconds"); }) == "(no error)");
  CHECK(edited([](auto& m) { m.erase("capture_identity"); }) == "(no error)");
  REQUIRE(good.contains("placement"));
  CHECK(edited([](auto& m) { m.erase("placement"); }) == "(no error)");
  // A run's checkpoint name must say the step it holds.
  CHECK(meta_error(good, checkpoints + handscs::checkpoint_name(99)) ==
        checkpoints + handscs::checkpoint_name(99) + ": named for another step than the 4 it holds (renamed?)");
  CHECK_NOTHROW(handscs::check_checkpoint_meta(good, dir + "/best.ckpt"));
  handscs::set_threads(2);
}

TEST_CASE("checkpoint meta: resume falls back past an edited checkpoint and keeps the valid one") {
  handscs::set_threads(1);
  const auto dir = fresh_dir("meta_resume");
  const auto checkpoints = train_four_steps(dir);
  const std::string newest = checkpoints + handscs::checkpoint_name(4);
  const std::string older = checkpoints + handscs::checkpoint_name(2);
  // Step 4's metadata edited and sealed again with a valid checksum.
  auto ckpt = handscs::load_checkpoint(newest);
  ckpt.meta["iteration"] = -5;
  handscs::save_checkpoint(newest, ckpt);

  auto config = four_step_config();
  config.train.iterations = 6;
  handscs::Trainer trainer(config, dir);
  REQUIRE(trainer.resume());
  CHECK(trainer.iteration() == 2);
  CHECK_FALSE(fs::exists(newest));
  CHECK(fs::exists(newest + ".unreadable"));  // set aside, not deleted
  trainer.step();
  trainer.step();
  trainer.save_checkpoint();  // step 4 again: the run keeps it and the valid step 2
  CHECK(fs::exists(older));
  CHECK(handscs::list_checkpoints(dir) ==
        std::vector<std::string>{checkpoints + handscs::checkpoint_name(4), older});
  CHECK(handscs::load_checkpoint(newest).meta["iteration"] == 4);

  // A checkpoint renamed to a later step is refused, not resumed from as step 99.
  fs::copy_file(older, checkpoints + handscs::checkpoint_name(99));
  handscs::Trainer again(config, dir);
  REQUIRE(again.resume());
  CHECK(again.iteration() == 4);

  // A newest "checkpoint" that is a device is refused unread, and the resume falls back past it.
  fs::remove(checkpoints + handscs::checkpoint_name(99) + ".unreadable");
  fs::create_symlink("/dev/zero", checkpoints + handscs::checkpoint_name(98));
  handscs::Trainer third(config, dir);
  REQUIRE(third.resume());
  CHECK(third.iteration() == 4);
  CHECK(fs::is_symlink(checkpoints + handscs::checkpoint_name(98) + ".unreadable"));
  handscs::set_threads(2);
}

TEST_CASE("checkpoint: a NaN sealed into a tensor is refused by name, and resume falls back past it") {
  handscs::set_threads(1);
  const auto dir = fresh_dir("nan_checkpoint");
  const auto checkpoints = train_four_steps(dir);
  const std::string newest = checkpoints + handscs::checkpoint_name(4);
  // Step 4's means poisoned and sealed again with a valid checksum.
  auto ckpt = handscs::load_checkpoint(newest);
  ckpt.tensors.at("gaussians/means")[0][1] = std::nan("");
  handscs::save_checkpoint(newest, ckpt);
  CHECK(handscs_test::error_of([&] { handscs::load_checkpoint(newest); }) ==
        newest + ": tensor 'gaussians/means' holds NaN or Inf values (a diverged run or an altered "
                 "file); use an earlier checkpoint of the run");
  // Inf in an optimiser moment likewise.
  auto older = handscs::load_checkpoint(checkpoints + handscs::checkpoint_name(2));
  older.tensors.at("adam/colors/0/v")[0][0] = std::numeric_limits<float>::infinity();
  const std::string edited = fresh_dir("inf_checkpoint") + ".ckpt";
  handscs::save_checkpoint(edited, older);
  CHECK_THROWS_WITH(handscs::load_checkpoint(edited), Catch::Contains("tensor 'adam/colors/0/v'"));

  auto config = four_step_config();
  config.train.iterations = 6;
  handscs::Trainer trainer(config, dir);
  REQUIRE(trainer.resume());
  CHECK(trainer.iteration() == 2);  // the NaN checkpoint was passed over, not resumed
  CHECK(fs::exists(newest + ".unreadable"));
  handscs::set_threads(2);
}

TEST_CASE("file reads: only regular files, and no more bytes than the format allows") {
  const auto dir = fresh_dir("regular_files");
  fs::create_directories(dir);
  // A named pipe would block the open until something writes to it.
  const std::string fifo = dir + "/config.json";
  REQUIRE(::mkfifo(fifo.c_str(), 0600) == 0);
  CHECK(handscs_test::error_of([&] { handscs::load_json_file(fifo); }) ==
        fifo + ": is not a regular file (a named pipe, a device or a socket); give a file");
  CHECK(handscs_test::error_of([&] { handscs::load_checkpoint(fifo); }) ==
        fifo + ": is not a regular file (a named pipe, a device or a socket); give a file");
  // A device's reads never end.
  CHECK(handscs_test::error_of([&] { handscs::load_checkpoint("/dev/zero"); }) ==
        "/dev/zero: is not a regular file (a named pipe, a device or a socket); give a file");
  CHECK(handscs_test::error_of([&] { handscs::read_file(dir); }) == dir + ": is a folder, not a file");
  // The bound is checked from the file's size, before reading.
  const std::string big = dir + "/big.bin";
  handscs::write_file_atomic(big, std::string(3 << 20, 'x'));
  CHECK(handscs_test::error_of([&] { handscs::read_file(big, 1 << 20); }) ==
        big + ": 3 MB, more than the 1 MB such a file can be");
  CHECK(handscs::read_file(big, 3 << 20).size() == (3u << 20));
  CHECK(handscs_test::error_of([&] { handscs::read_file(dir + "/none"); }) ==
        dir + "/none: cannot open file");
}

TEST_CASE("checkpoint meta: a resume that changes the experiment's data is refused, unless asked") {
  handscs::set_threads(1);
  const auto dir = fresh_dir("meta_experiment");
  train_four_steps(dir);
  auto changed = four_step_config();
  changed.train.iterations = 6;
  changed.data.held_out_poses = 4;
  changed.data.cache.budget_mb = 16;  // how images are read, not which: not a change of experiment
  const auto newest = dir + "/checkpoints/" + handscs::checkpoint_name(4);
  {
    handscs::Trainer trainer(changed, dir);
    CHECK(handscs_test::error_of([&] { trainer.resume(); }) ==
          newest + ": the config changes what the run trains and tests on (checkpoint -> given):\n"
                   "  data.held_out_poses: 3 -> 4\n"
                   "resume with the run's data settings, or pass --resume-changing-data if you "
                   "mean it (its scores then mix two experiments)");
    CHECK(fs::exists(newest));  // nothing set aside or changed
  }
  handscs::Trainer trainer(changed, dir);
  REQUIRE(trainer.resume(/*allow_changed_data=*/true));
  CHECK(trainer.iteration() == 4);
  // The identity keys are exactly the ones that choose images: a cache setting is not one.
  auto stored = four_step_config();
  CHECK(handscs::experiment_differences(stored, changed) ==
        std::vector<std::string>{"data.held_out_poses: 3 -> 4"});
  // A validation split moves images from training to the test set: either kind is a change of
  // experiment, so a resume with another one is refused like the change above.
  auto by_cameras = stored;
  by_cameras.data.validation_cameras = {"400014", "400042"};
  auto by_poses = stored;
  by_poses.data.validation_poses = 2;
  CHECK(handscs::experiment_differences(stored, by_cameras) ==
        std::vector<std::string>{"data.validation_cameras: [] -> [\"400014\",\"400042\"]"});
  CHECK(handscs::experiment_differences(by_cameras, by_poses) ==
        std::vector<std::string>{"data.validation_cameras: [\"400014\",\"400042\"] -> []",
                                 "data.validation_poses: 0 -> 2"});
  // Another capture is another experiment too (its root named as written in each config).
  auto elsewhere = stored;
  elsewhere.data.root = "/another/capture";
  CHECK(handscs::experiment_differences(stored, elsewhere) ==
        std::vector<std::string>{"data.root: \"" + stored.data.root + "\" -> \"/another/capture\""});
  handscs::set_threads(2);
}

TEST_CASE("capture identity: kept by another split, a copy and the thread count; not by another seed") {
  const auto identity_of = [](const handscs::CaptureConfig& data) {
    const handscs::Capture capture = handscs::Capture::open(data);
    return handscs::capture_identity(capture, capture.frames());
  };
  const auto config = tiny_run_config();
  handscs::set_threads(1);
  const auto reference = identity_of(config.data);
  CHECK(reference.frames > 0);
  handscs::set_threads(2);
  CHECK(handscs::identity_differences(reference, identity_of(config.data)).empty());
  auto other_split = config.data;
  other_split.held_out_poses = 5;
  other_split.validation_poses = 2;
  CHECK(handscs::identity_differences(reference, identity_of(other_split)).empty());
  const std::string copy = fresh_dir("identity_copy");
  fs::copy(config.data.root, copy, fs::copy_options::recursive);
  auto copied = config.data;
  copied.root = copy;
  CHECK(handscs::identity_differences(reference, identity_of(copied)).empty());
  // The JSON form reads back.
  const auto read = handscs::CaptureIdentity::from_json(reference.to_json(), "x");
  CHECK(handscs::identity_differences(reference, read).empty());

  // Another seed of the preset: the same image names and camera ids, other cameras and hands.
  const std::string other = fresh_dir("identity_other_seed");
  auto preset = handscs::synth_preset("tiny");
  preset.seed += 1;
  handscs::generate_synth_capture(preset, other);
  auto other_capture = config.data;
  other_capture.root = other;
  CHECK(handscs::identity_differences(reference, identity_of(other_capture)) ==
        std::vector<std::string>{"the cameras' calibration", "the image names or the annotated hands"});
  // One frame fewer (its image gone): the count is named too.
  const handscs::Capture full = handscs::Capture::open(copied);
  fs::remove(full.frames().front().image_path);
  const auto fewer = identity_of(copied);
  CHECK(fewer.frames == reference.frames - 1);
  CHECK(handscs::identity_differences(reference, fewer).front() ==
        std::to_string(reference.frames - 1) + " usable frames (the run's capture: " +
            std::to_string(reference.frames) + ")");
}
