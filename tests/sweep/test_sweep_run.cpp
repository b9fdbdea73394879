// handscs-bench end to end on the tiny capture: --threads reaches every run, a run that fails keeps
// its row with the reason (a budget below train.log_every too) and the others are scored, and the
// sweep then exits with 3.
#include <catch2/catch.hpp>

#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>

#include "core/atomic_file.h"
#include "core/csv_table.h"
#include "test_support.h"

namespace fs = std::filesystem;
using handscs_test::kBin;
using handscs_test::kSource;

// An empty folder `dir` holding a fresh tiny synthetic capture, dir/capture (returned).
std::string fresh_tiny_capture(const std::string& dir) {
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string capture = dir + "/capture";
  REQUIRE(std::system((kBin + "/handscs-synth --preset tiny --threads 1 --log-level warn --out " +
                       capture + " > " + dir + "/synth.log 2>&1").c_str()) == 0);
  return capture;
}

TEST_CASE("sweep run: --threads reaches the runs, a failed run is kept and the exit status is 3") {
  const std::string dir = handscs_test::scratch_path("handscs_test_sweep_run", "case");
  const std::string capture = fresh_tiny_capture(dir);
  const std::string sweep = handscs_test::scratch_file("handscs_test_sweep_run", "sweep.json", R"({
    "run_config": ")" + kSource + R"(/configs/tiny.json", "budgets": [10], "eval_images": 2,
    "threads": 2,
    "points": [{"name": "good", "set": ["train.log_every=5"]},
               {"name": "bad", "set": ["train.no_such_key=1"]},
               {"name": "unlogged", "set": ["train.log_every=20"]}]})");
  const int status = std::system((kBin + "/handscs-bench --sweep " + sweep + " --out " + dir +
                                  "/out --capture " + capture + " --threads 1 > " + dir +
                                  "/bench.log 2>&1").c_str());
  REQUIRE(WIFEXITED(status));
  CHECK(WEXITSTATUS(status) == 3);
  const handscs::CsvTable results = handscs::read_csv(dir + "/out/results.csv");
  REQUIRE(results.rows.size() == 3);
  for (size_t r = 0; r < results.rows.size(); ++r) {
    INFO(results.at(r, "point"));
    CHECK(results.at(r, "threads") == "1");  // the sweep file says 2; --threads wins
    if (results.at(r, "point") == "good") {
      CHECK(results.at(r, "status") == "ok");
      CHECK(results.at(r, "eval_images") == "2");
    } else if (results.at(r, "point") == "bad") {
      CHECK(results.at(r, "status") == "train failed (1)");
    } else {  // 10 steps logged every 20: trained, but nothing to summarise
      CHECK(results.at(r, "status") == "no step logged");
    }
  }
  const std::string log = handscs::read_file(dir + "/bench.log");
  CHECK(log.find("2 of 3 runs failed") != std::string::npos);
  CHECK(log.find("sweep unlogged@10: " + dir + "/out/runs/unlogged_10/metrics.csv has no rows: a budget "
                 "of 10 steps is below the run config's train.log_every; set train.log_every to at "
                 "most the budget") != std::string::npos);
}

TEST_CASE("sweep run: a missing run config or capture is named before any run trains") {
  const std::string dir = handscs_test::scratch_path("handscs_test_sweep_run", "refused");
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string missing_config = handscs_test::scratch_file("handscs_test_sweep_run", "missing.json", R"({
    "run_config": "no_such_run.json", "budgets": [10], "points": [{"name": "a", "set": []}]})");
  const std::string bench = kBin + "/handscs-bench --out " + dir + "/out --threads 1 --sweep ";
  const auto exit_code = [&](const std::string& command) {
    const int status = std::system((command + " > " + dir + "/bench.log 2>&1").c_str());
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  };
  CHECK(exit_code(bench + missing_config + " --capture " + dir) == 1);
  CHECK(handscs::read_file(dir + "/bench.log")
            .find(fs::path(missing_config).parent_path().string() +
                  "/no_such_run.json: the sweep's run_config is not a file") != std::string::npos);
  const std::string good = handscs_test::scratch_file("handscs_test_sweep_run", "good.json", R"({
    "run_config": ")" + kSource + R"(/configs/tiny.json", "budgets": [10], "points": [{"name": "a", "set": []}]})");
  CHECK(exit_code(bench + good + " --capture /nonexistent/capture") == 1);
  CHECK(handscs::read_file(dir + "/bench.log").find("/nonexistent/capture: --capture is not a folder") !=
        std::string::npos);
  CHECK_FALSE(fs::exists(dir + "/out/results.csv"));
}

// The state a sweep stopped half-way leaves is made without a race: a finished run's folder is
// copied into a new sweep folder with its last checkpoint taken away, as if the machine had gone
// after the step-10 checkpoint (the trainer drops the log rows past the checkpoint it resumes from).
namespace {

struct StraightSweep {
  std::string dir, capture, sweep;
  handscs::CsvTable done;  // results.csv of the uninterrupted sweep
  // Runs the sweep into `out` (--keep-runs); its exit status.
  int bench(const std::string& out) const {
    const int status = std::system((kBin + "/handscs-bench --sweep " + sweep + " --out " + out +
                                    " --capture " + capture + " --keep-runs > " + out + ".log 2>&1").c_str());
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  }
  // A copy of the finished run in out/runs as a stop after step 10 leaves it; its folder.
  std::string stopped_copy(const std::string& out) const {
    fs::remove_all(out);
    fs::create_directories(out + "/runs");
    fs::copy(dir + "/straight/runs/p_20", out + "/runs/p_20", fs::copy_options::recursive);
    REQUIRE(fs::remove(out + "/runs/p_20/checkpoints/step_00000020.ckpt"));
    REQUIRE(fs::exists(out + "/runs/p_20/checkpoints/step_00000010.ckpt"));
    return out + "/runs/p_20";
  }
};

// One tiny capture and one uninterrupted 20-step sweep, made once for every section below.
const StraightSweep& straight_sweep() {
  static const StraightSweep made = [] {
    StraightSweep s;
    s.dir = handscs_test::scratch_path("handscs_test_sweep_run", "resume");
    s.capture = fresh_tiny_capture(s.dir);
    s.sweep = handscs_test::scratch_file("handscs_test_sweep_run", "resume.json", R"({
      "run_config": ")" + kSource + R"(/configs/tiny.json", "budgets": [20], "eval_images": 2,
      "threads": 1,
      "points": [{"name": "p", "set": ["train.log_every=5", "train.checkpoint_every=10"]}]})");
    REQUIRE(s.bench(s.dir + "/straight") == 0);
    s.done = handscs::read_csv(s.dir + "/straight/results.csv");
    return s;
  }();
  return made;
}

// Replaces the first `from` in the run's sweep_run.json by `to`.
void edit_identity(const std::string& run, const std::string& from, const std::string& to) {
  std::string identity = handscs::read_file(run + "/sweep_run.json");
  const auto at = identity.find(from);
  REQUIRE(at != std::string::npos);
  identity.replace(at, from.size(), to);
  handscs::write_file_atomic(run + "/sweep_run.json", identity);
}

}  // namespace

TEST_CASE("sweep run: a run stopped half-way continues from its checkpoint and scores as if never stopped") {
  const StraightSweep& s = straight_sweep();
  const handscs::CsvTable& done = s.done;
  REQUIRE(done.rows.size() == 1);
  REQUIRE(done.at(0, "status") == "ok");
  CHECK_FALSE(done.at(0, "train_wall_s").empty());
  CHECK(done.at(0, "resumed_from_step").empty());
  // The sweep into `out` trains its one run from step 0, to the scores of the straight run.
  const auto trained_afresh = [&](const std::string& out) {
    REQUIRE(s.bench(out) == 0);
    const handscs::CsvTable fresh = handscs::read_csv(out + "/results.csv");
    REQUIRE(fresh.rows.size() == 1);
    CHECK(fresh.at(0, "status") == "ok");
    CHECK(fresh.at(0, "resumed_from_step").empty());
    CHECK_FALSE(fresh.at(0, "train_wall_s").empty());
    CHECK(fresh.at(0, "psnr") == done.at(0, "psnr"));
    CHECK_FALSE(fs::exists(out + "/runs/p_20/train.interrupted.1.log"));
  };

  SECTION("the same command continues from step 10 to the same scores") {
    const std::string out = s.dir + "/continued";
    const std::string run = s.stopped_copy(out);
    REQUIRE(s.bench(out) == 0);
    const handscs::CsvTable resumed = handscs::read_csv(out + "/results.csv");
    REQUIRE(resumed.rows.size() == 1);
    CHECK(resumed.at(0, "status") == "ok");
    CHECK(resumed.at(0, "resumed_from_step") == "10");
    CHECK(resumed.at(0, "train_wall_s").empty());  // the last attempt's would understate it
    CHECK(resumed.at(0, "peak_rss_mb").empty());
    for (const char* column : {"psnr", "ssim", "lpips", "gaussians", "eval_images"}) {
      INFO(column);
      CHECK(resumed.at(0, column) == done.at(0, column));  // resuming is exact
    }
    CHECK(fs::exists(run + "/train.interrupted.1.log"));
    CHECK(handscs::read_file(out + ".log").find("was stopped half-way; continuing it") != std::string::npos);
    CHECK(handscs::read_file(out + "/summary.md").find("| continued from step 10 |") != std::string::npos);
  }
  SECTION("a folder started by another command is trained afresh") {
    const std::string out = s.dir + "/other_command";
    const std::string run = s.stopped_copy(out);
    edit_identity(run, "train.checkpoint_every=10", "train.checkpoint_every=5");
    trained_afresh(out);
    CHECK(handscs::read_file(run + "/sweep_run.json") ==
          handscs::read_file(s.dir + "/straight/runs/p_20/sweep_run.json"));
  }
  SECTION("a folder started by another run config or handscs-train binary is trained afresh") {
    const std::string out = s.dir + "/other_build";
    const std::string run = s.stopped_copy(out);
    edit_identity(run, GENERATE(std::string("\"modified_ns\": "), std::string("\"held_out_poses\": ")),
                  "\"x\": 1, \"y\": ");
    trained_afresh(out);
  }
  SECTION("a stopped run whose checkpoint cannot be loaded is trained afresh") {
    const std::string out = s.dir + "/damaged";
    const std::string run = s.stopped_copy(out);
    fs::resize_file(run + "/checkpoints/step_00000010.ckpt", 100);  // torn
    trained_afresh(out);
    CHECK(handscs::read_file(out + ".log").find("none of the stopped run's checkpoints loads") !=
          std::string::npos);
  }
  SECTION("a continued run that fails otherwise keeps its checkpoint for the next try") {
    const std::string out = s.dir + "/failing";
    const std::string run = s.stopped_copy(out);
    const std::string config = handscs::read_file(run + "/config.json");
    handscs::write_file_atomic(run + "/config.json", "{ not json");
    CHECK(s.bench(out) == 3);
    CHECK(handscs::read_csv(out + "/results.csv").at(0, "status") == "train failed (1)");
    CHECK(fs::exists(run + "/checkpoints/step_00000010.ckpt"));
    handscs::write_file_atomic(run + "/config.json", config);
    REQUIRE(s.bench(out) == 0);
    const handscs::CsvTable resumed = handscs::read_csv(out + "/results.csv");
    CHECK(resumed.at(0, "resumed_from_step") == "10");
    CHECK(resumed.at(0, "psnr") == done.at(0, "psnr"));
    CHECK(fs::exists(run + "/train.interrupted.2.log"));  // each attempt's log is kept
  }
  SECTION("a results.csv written before resumed_from_step existed is read, and gains the column") {
    const std::string out = s.dir + "/earlier";
    fs::remove_all(out);
    fs::create_directories(out);
    handscs::CsvTable earlier = done;
    REQUIRE(static_cast<size_t>(earlier.column("resumed_from_step")) == earlier.header.size() - 1);
    earlier.header.pop_back();
    for (auto& row : earlier.rows) row.pop_back();
    earlier.rows[0][0] = "older";  // a finished run of an earlier version, not in this sweep
    handscs::write_csv_atomic(out + "/results.csv", earlier);
    REQUIRE(s.bench(out) == 0);  // p trains and its row is added
    const handscs::CsvTable read = handscs::read_csv(out + "/results.csv");
    CHECK(read.header == done.header);
    REQUIRE(read.rows.size() == 2);
    auto older = earlier.rows[0];
    older.push_back("");
    CHECK(read.rows[0] == older);
    CHECK(read.at(1, "point") == "p");
    CHECK(read.at(1, "psnr") == done.at(0, "psnr"));
  }
}
