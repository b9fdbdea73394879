// Run-folder safety against hand-made folders: a folder holding a run is refused and left byte for
// byte unless --overwrite, which replaces that run's files only, putting them back byte for byte
// when the new run ends (or is killed) before its first checkpoint; temporaries of dead writers go,
// those of live ones stay; a resume drops log rows after its checkpoint, torn rows too, and keeps
// the log one table when the run's columns change; an incompatible resume names the keys and
// changes nothing; a user error at step 1 writes nothing.
#include "test_support.h"
#include "catch_torch.h"

#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <map>

#include "core/atomic_file.h"
#include "core/config.h"
#include "core/csv_table.h"
#include "core/error.h"
#include "core/threads.h"
#include "run/checkpoint.h"
#include "tiny_capture.h"
#include "train/run_folder.h"
#include "train/set_aside_run.h"
#include "train/trainer.h"

namespace fs = std::filesystem;

namespace {

using handscs_test::snapshot;

void write(const std::string& path, const std::string& text) {
  fs::create_directories(fs::path(path).parent_path());
  std::ofstream(path) << text;
}

}  // namespace

TEST_CASE("run folder: a folder holding a run is refused, and --overwrite replaces only that run") {
  const auto dir = handscs_test::fresh_dir("folder_guard");
  handscs::refuse_run_folder_without_overwrite(dir, false);  // absent: fine
  fs::create_directories(dir + "/cache");
  write(dir + "/cache/masks-1/a.png", "mask");
  handscs::refuse_run_folder_without_overwrite(dir, false);  // a mask cache alone is no run
  write(dir + "/config.json", "{}");
  write(dir + "/metrics.csv", "iteration\n1\n");
  write(dir + "/checkpoints/step_00000010.ckpt", "ten");
  write(dir + "/checkpoints/step_00000020.ckpt", "twenty");
  write(dir + "/validation/step_00000020.png", "png");
  write(dir + "/eval/metrics.json", "the old run's scores");
  write(dir + "/notes.txt", "the user's own file");
  const auto before = snapshot(dir);
  CHECK_THROWS_WITH(handscs::refuse_run_folder_without_overwrite(dir, false),
                    dir + " holds a run (2 checkpoints (newest step_00000020.ckpt), config.json, "
                          "metrics.csv, validation/); continue it with --resume, replace it with "
                          "--overwrite, or choose another --out");
  CHECK(snapshot(dir) == before);
  {
    handscs::SetAsideRun replaced(dir);
    CHECK(replaced.holds_files());
    CHECK_FALSE(handscs::inspect_run_folder(dir).holds_run());
    replaced.discard();  // the new run's first checkpoint
  }
  const auto after = snapshot(dir);
  CHECK(after.size() == 2);
  CHECK(after.count(dir + "/cache/masks-1/a.png") == 1);
  CHECK(after.count(dir + "/notes.txt") == 1);
  CHECK_FALSE(handscs::inspect_run_folder(dir).holds_run());
}

TEST_CASE("run folder: a new run that ends before its first checkpoint puts the old run back") {
  const auto dir = handscs_test::fresh_dir("folder_aside");
  write(dir + "/config.json", "{\"old\": true}");
  write(dir + "/metrics.csv", "iteration\n1\n");
  write(dir + "/checkpoints/step_00000020.ckpt", "twenty");
  write(dir + "/camera_color.csv", "old colours");
  write(dir + "/notes.txt", "the user's own file");
  const auto before = snapshot(dir);
  // An error after the set-aside (a failing first step): the new run's files go, the old come back.
  CHECK(handscs_test::error_of([&] {
          handscs::SetAsideRun replaced(dir);
          write(dir + "/config.json", "{\"new\": true}");
          write(dir + "/metrics.csv", "iteration\n");
          write(dir + "/validation/step_00000005.png", "new");
          throw handscs::Error("step 1 failed");
        }) == "step 1 failed");
  CHECK(snapshot(dir) == before);

  // A killed run (no destructor runs): the old run waits set aside, and the next handscs-train in
  // the folder puts it back byte for byte.
  const pid_t child = fork();
  REQUIRE(child >= 0);
  if (child == 0) {
    auto* replaced = new handscs::SetAsideRun(dir);  // never destroyed: as under kill -9
    (void)replaced;
    write(dir + "/metrics.csv", "iteration\n");
    _exit(0);
  }
  int status = 0;
  waitpid(child, &status, 0);
  REQUIRE(fs::is_directory(dir + "/.overwritten." + std::to_string(child)));
  CHECK_FALSE(handscs::inspect_run_folder(dir).checkpoints.size() > 0);
  handscs::recover_set_aside_runs(dir);
  CHECK(snapshot(dir) == before);

  // Killed after the new run's first checkpoint, before the old run was deleted: the deletion is
  // finished and the new run kept.
  const pid_t second = fork();
  REQUIRE(second >= 0);
  if (second == 0) {
    auto* replaced = new handscs::SetAsideRun(dir);
    (void)replaced;
    write(dir + "/checkpoints/step_00000005.ckpt", "five");
    _exit(0);
  }
  waitpid(second, &status, 0);
  handscs::recover_set_aside_runs(dir);
  const auto kept = snapshot(dir);
  CHECK(kept.size() == 2);
  CHECK(kept.count(dir + "/checkpoints/step_00000005.ckpt") == 1);
  CHECK(kept.count(dir + "/notes.txt") == 1);

  // A live process's set-aside run is never touched: two runs in one folder are refused.
  fs::create_directories(dir + "/.overwritten.1");  // pid 1 (init) is always alive
  CHECK(handscs_test::error_of([&] { handscs::recover_set_aside_runs(dir); }) ==
        dir + ": another handscs-train (process 1) is replacing the run in this folder; wait for it "
              "or choose another --out");
  fs::remove(dir + "/.overwritten.1");
}

TEST_CASE("run folder: checkpoints are ordered by the step their name says, as a number") {
  const auto dir = handscs_test::fresh_dir("folder_order");
  // 8-digit padding orders names as text only up to step 99,999,999.
  for (const char* name : {"step_00000005.ckpt", "step_99999999.ckpt", "step_100000000.ckpt",
                           "step_x.ckpt", "notes.ckpt"})
    write(dir + "/checkpoints/" + name, "c");
  const auto files = handscs::list_checkpoints(dir);
  REQUIRE(files.size() == 4);
  CHECK(files[0] == dir + "/checkpoints/step_100000000.ckpt");
  CHECK(files[1] == dir + "/checkpoints/step_99999999.ckpt");
  CHECK(files[2] == dir + "/checkpoints/step_00000005.ckpt");
  CHECK(files[3] == dir + "/checkpoints/step_x.ckpt");  // no number: last
  CHECK(handscs::inspect_run_folder(dir).checkpoints == files);
}

TEST_CASE("run folder: temporaries of dead writers are removed, a live writer's are kept") {
  const auto dir = handscs_test::fresh_dir("folder_tmp");
  const pid_t child = fork();
  REQUIRE(child >= 0);
  if (child == 0) _exit(0);
  waitpid(child, nullptr, 0);  // reaped: no process has this pid now
  const auto dead = dir + "/checkpoints/step_00000005.ckpt.tmp." + std::to_string(child);
  const auto live = dir + "/config.json.tmp." + std::to_string(getpid());
  write(dead, "torn");
  write(live, "being written");
  write(dir + "/checkpoints/step_00000004.ckpt", "whole");
  write(dir + "/x.tmp.notapid", "not ours");
  CHECK(handscs::remove_stale_temporaries(dir) == 1);
  CHECK_FALSE(fs::exists(dead));
  CHECK(fs::exists(live));
  CHECK(fs::exists(dir + "/checkpoints/step_00000004.ckpt"));
  CHECK(fs::exists(dir + "/x.tmp.notapid"));
}

TEST_CASE("run folder: a resume's log keeps the rows up to its step, and no torn row") {
  const auto dir = handscs_test::fresh_dir("folder_log");
  const auto path = dir + "/metrics.csv";
  write(path, "iteration,loss,psnr\n10,0.5,20\n20,0.4,21\n30,0.3,22\n40,0.2");
  handscs::truncate_metrics_log(path, 30);
  CHECK(handscs::read_file(path) == "iteration,loss,psnr\n10,0.5,20\n20,0.4,21\n30,0.3,22\n");
  handscs::truncate_metrics_log(path, 20);
  CHECK(handscs::read_file(path) == "iteration,loss,psnr\n10,0.5,20\n20,0.4,21\n");
  handscs::truncate_metrics_log(path, 0);
  CHECK(handscs::read_file(path) == "iteration,loss,psnr\n");
  handscs::truncate_metrics_log(dir + "/absent.csv", 5);
  CHECK_FALSE(fs::exists(dir + "/absent.csv"));
}

TEST_CASE("run folder: a metrics log of other columns gains the missing ones, no row lost") {
  const auto dir = handscs_test::fresh_dir("folder_columns");
  fs::create_directories(dir);
  const auto path = dir + "/metrics.csv";
  const std::vector<std::string> columns = {"iteration", "loss", "gate", "decoded_fraction"};

  // A new log: the run's columns.
  CHECK(handscs::prepare_metrics_log(path, columns) == columns);
  CHECK(handscs::read_file(path) == "iteration,loss,gate,decoded_fraction\n");

  // All columns present, in another order: the file's order, the file untouched.
  write(path, "loss,iteration,decoded_fraction,gate\n0.5,10,1,0.1\n");
  CHECK(handscs::prepare_metrics_log(path, columns) ==
        std::vector<std::string>{"loss", "iteration", "decoded_fraction", "gate"});
  CHECK(handscs::read_file(path) == "loss,iteration,decoded_fraction,gate\n0.5,10,1,0.1\n");

  // An older log without two of them: they are appended, its rows padded; a torn row (fewer cells
  // than its own header) is not padded, so the resume's truncation still drops it; a row that
  // already has the cells (an older build logged them without a header) keeps them.
  write(path, "iteration,loss\n10,0.5\n20,0.4,0.2,1\n30\n");
  const auto aligned = handscs::prepare_metrics_log(path, columns);
  CHECK(aligned == std::vector<std::string>{"iteration", "loss", "gate", "decoded_fraction"});
  CHECK(handscs::read_file(path) == "iteration,loss,gate,decoded_fraction\n10,0.5,,\n20,0.4,0.2,1\n30\n");
  handscs::truncate_metrics_log(path, 100);
  CHECK(handscs::read_file(path) == "iteration,loss,gate,decoded_fraction\n10,0.5,,\n20,0.4,0.2,1\n");
  // Again with the same columns: nothing to do.
  CHECK(handscs::prepare_metrics_log(path, columns) == aligned);
  CHECK(handscs::read_csv(path).rows.size() == 2);
}

TEST_CASE("run folder: resumes that switch train.cull keep one table in metrics.csv") {
  handscs::set_threads(2);
  auto config = handscs_test::tiny_run_config();
  config.train.log_every = 1;
  const auto dir = handscs_test::fresh_dir("folder_cull_columns");
  const auto run_until = [&](bool cull, int64_t steps, bool resume) {
    auto c = config;
    c.train.cull.enabled = cull;
    c.train.iterations = steps;
    handscs::Trainer trainer(c, dir);
    if (resume) REQUIRE(trainer.resume());
    trainer.run();  // logs every step and checkpoints at its end
  };
  run_until(false, 2, false);
  run_until(true, 4, true);   // the cull's column appears
  run_until(false, 6, true);  // and stays, empty
  const auto table = handscs::read_csv(dir + "/metrics.csv");  // throws on a row of another length
  REQUIRE(table.rows.size() == 6);
  CHECK(table.header.back() == "decoded_fraction");
  for (size_t row = 0; row < 6; ++row) {
    INFO("step " << row + 1);
    CHECK(table.at(row, "iteration") == std::to_string(row + 1));
    CHECK(table.at(row, "decoded_fraction").empty() == (row < 2 || row >= 4));
    CHECK_FALSE(table.at(row, "gate_geometry").empty());
  }
}

TEST_CASE("run folder: a run stopped by a user error at step 1 leaves the folder as it was") {
  handscs::set_threads(2);
  auto config = handscs_test::tiny_run_config();
  // Passes the whole-image check (167 x 0.066 rounds to 11) but not the crops around the hand.
  config.train.resolution_scale = 0.066;
  const auto dir = handscs_test::fresh_dir("folder_step1_error");
  fs::create_directories(dir);
  write(dir + "/notes.txt", "the user's own file");
  const auto before = snapshot(dir);
  const std::string error = handscs_test::error_of([&] {
    handscs::Trainer trainer(config, dir);
    trainer.run();
  });
  INFO(error);
  REQUIRE(error.find("scales the crop around the hand") != std::string::npos);
  auto after = snapshot(dir);  // the mask cache may be new: shared, keyed by its settings, no run
  for (auto it = after.begin(); it != after.end();)
    it = it->first.rfind(dir + "/cache/", 0) == 0 ? after.erase(it) : std::next(it);
  CHECK(after == before);
  CHECK_FALSE(handscs::inspect_run_folder(dir).holds_run());
  CHECK_NOTHROW(handscs::refuse_run_folder_without_overwrite(dir, /*overwrite=*/false));  // no --overwrite needed
}

TEST_CASE("run folder: a fresh run that ends before its first checkpoint removes what it wrote, and only that") {
  const auto dir = handscs_test::fresh_dir("folder_fresh_fails");
  write(dir + "/notes.txt", "the user's own file");
  write(dir + "/eval/metrics.json", "the user's own scores");  // a run file name, but no run: not the new run's
  write(dir + "/cache/masks-1/a.png", "mask");
  const auto before = snapshot(dir);
  // A user error at step 16, after the first logged step wrote config.json and metrics.csv.
  CHECK(handscs_test::error_of([&] {
          handscs::SetAsideRun guard(dir);
          CHECK_FALSE(guard.holds_files());
          write(dir + "/config.json", "{\"new\": true}");
          write(dir + "/metrics.csv", "iteration\n1\n");
          write(dir + "/validation/step_00000010.png", "new");
          write(dir + "/left/pose_refine.csv", "new");
          write(dir + "/eval/metrics.json", "the user's own scores");
          throw handscs::Error("the hand masks of the first 16 training images are all empty");
        }) == "the hand masks of the first 16 training images are all empty");
  CHECK(snapshot(dir) == before);
  CHECK_NOTHROW(handscs::refuse_run_folder_without_overwrite(dir, /*overwrite=*/false));  // no --overwrite needed
  // Past its first checkpoint the run's files stay.
  {
    handscs::SetAsideRun guard(dir);
    write(dir + "/config.json", "{\"new\": true}");
    write(dir + "/checkpoints/step_00000010.ckpt", "ten");
    guard.discard();
  }
  CHECK(handscs::inspect_run_folder(dir).holds_run());
  CHECK(handscs::read_file(dir + "/config.json") == "{\"new\": true}");
}

TEST_CASE("run folder: config differences are listed key by key") {
  const handscs::json a = {{"x", 1}, {"s", {{"c", 2}, {"d", 3}}}};
  const handscs::json b = {{"x", 1}, {"s", {{"c", 5}}}, {"e", true}};
  const auto d = handscs::json_differences(a, b, "model");
  REQUIRE(d.size() == 3);
  CHECK(d[0] == "model.e: (absent) -> true");
  CHECK(d[1] == "model.s.c: 2 -> 5");
  CHECK(d[2] == "model.s.d: 3 -> (absent)");
  CHECK(handscs::json_differences(a, a).empty());
}

TEST_CASE("run folder: an incompatible resume names what differs and changes nothing") {
  handscs::set_threads(2);
  auto config = handscs_test::tiny_run_config();
  config.train.iterations = 2;
  const auto dir = handscs_test::fresh_dir("folder_resume");
  {
    handscs::Trainer trainer(config, dir);
    trainer.run();
  }
  const auto before = snapshot(dir);
  auto other = config;
  other.model.embedding_dim = 16;
  other.model.decoder_hidden = 64;
  handscs::Trainer trainer(other, dir);
  try {
    trainer.resume();
    FAIL("resume of another model succeeded");
  } catch (const handscs::Error& e) {
    const std::string message = e.what();
    INFO(message);
    CHECK(message.find("its one checkpoint cannot be resumed; nothing was changed") != std::string::npos);
    CHECK(message.find("model.embedding_dim: 32 -> 16") != std::string::npos);
    CHECK(message.find("model.decoder_hidden: 256 -> 64") != std::string::npos);
  }
  CHECK(snapshot(dir) == before);
}
