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

TEST_CASE("sweep run: --threads reaches the runs, a failed run is kept and the exit status is 3") {
  const std::string dir = handscs_test::scratch_path("handscs_test_sweep_run", "case");
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string capture = dir + "/capture";
  REQUIRE(std::system((kBin + "/handscs-synth --preset tiny --threads 1 --log-level warn --out " +
                       capture + " > " + dir + "/synth.log 2>&1").c_str()) == 0);
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
