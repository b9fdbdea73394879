// The sweep's plumbing: sweep files (values and the exact error texts), child processes (exit
// status, signals, peak memory, a missing program) and the resumable CSV (quoting round trip).
#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/csv_table.h"
#include "sweep/subprocess.h"
#include "sweep/sweep_config.h"
#include "test_support.h"

namespace {

namespace fs = std::filesystem;
using handscs_test::kSource;

std::string scratch(const std::string& name) {
  return handscs_test::scratch_path("handscs_test_sweep", name);
}

std::string write(const std::string& name, const std::string& text) {
  return handscs_test::scratch_file("handscs_test_sweep", name, text);
}

using handscs_test::error_of;

}  // namespace

TEST_CASE("sweep files: the shipped sweeps load, and a point's budgets and threads override") {
  int shipped = 0;
  for (const auto& entry : fs::directory_iterator(kSource + "/configs/sweeps")) {
    if (entry.path().extension() != ".json") continue;
    ++shipped;
    INFO(entry.path().string());
    const auto c = handscs::load_sweep_config(entry.path().string());
    CHECK(fs::exists(c.run_config));
    CHECK_FALSE(c.points.empty());
    CHECK_FALSE(c.budgets.empty());
  }
  CHECK(shipped >= 10);
  const std::string path = write("s.json", R"({
    "run_config": "../run.json", "budgets": [100, 200], "eval_images": 60, "threads": 2,
    "points": [{"name": "default"},
               {"name": "one_thread", "threads": 1, "budgets": [50], "set": ["a.b=1", "c=2"]}],
    "raster": {"gaussians": [1000, 10000], "threads": [2], "repeats": 3}})");
  const auto c = handscs::load_sweep_config(path);
  CHECK(c.run_config == (fs::path(path).parent_path().parent_path() / "run.json").string());
  CHECK(c.budgets == std::vector<int>{100, 200});
  CHECK(c.eval_images == 60);
  REQUIRE(c.points.size() == 2);
  CHECK(c.points[0].set.empty());
  CHECK(c.points[0].threads == 0);
  CHECK(c.points[1].threads == 1);
  CHECK(c.points[1].budgets == std::vector<int>{50});
  CHECK(c.points[1].set == std::vector<std::string>{"a.b=1", "c=2"});
  CHECK(c.raster.gaussians == std::vector<int>{1000, 10000});
  CHECK(c.raster.threads == std::vector<int>{2});
  CHECK(c.raster.repeats == 3);

  // Settings the sweep shares come before each point's own (which therefore win).
  const std::string shared = write("shared.json", R"({
    "run_config": "../run.json", "budgets": [100], "set": ["train.camera_color=off"],
    "points": [{"name": "plain"}, {"name": "gain", "set": ["train.camera_color=gain"]}]})");
  const auto d = handscs::load_sweep_config(shared);
  REQUIRE(d.points.size() == 2);
  CHECK(d.points[0].set == std::vector<std::string>{"train.camera_color=off"});
  CHECK(d.points[1].set ==
        std::vector<std::string>{"train.camera_color=off", "train.camera_color=gain"});
}

TEST_CASE("sweep files: bad files give errors naming the file and key") {
  auto load = [](const std::string& text) {
    const std::string path = write("bad.json", text);
    return error_of([&] { handscs::load_sweep_config(path); });
  };
  const std::string f = scratch("bad.json");
  CHECK(load(R"({"budgets": [1], "points": [{"name": "a"}]})") ==
        f + ": run_config: missing (required)");
  CHECK(load(R"({"run_config": "x", "budgets": [], "points": [{"name": "a"}]})") ==
        f + ": budgets: needs at least one training budget");
  CHECK(load(R"({"run_config": "x", "budgets": [0], "points": [{"name": "a"}]})") ==
        f + ": budgets[0]: 0 is outside [1, 10000000]");
  CHECK(load(R"({"run_config": "x", "budgets": [5], "points": []})") ==
        f + ": points: expected a non-empty array of {\"name\", \"set\"} objects");
  CHECK(load(R"({"run_config": "x", "budgets": [5], "points": [{"name": "a b"}]})") ==
        f + ": points[0].name: \"a b\" must match [A-Za-z0-9_.-]+ (it names a folder)");
  CHECK(load(R"({"run_config": "x", "budgets": [5], "points": [{"name": "a"}, {"name": "a"}]})") ==
        f + ": points[1].name: \"a\" is used twice");
  CHECK(load(R"({"run_config": "x", "budgets": [5], "points": [{"name": "a", "set": "k=1"}]})") ==
        f + ": points[0].set: expected array, got string");
  CHECK(load(R"({"run_config": "x", "budgets": [5], "set": "k=1", "points": [{"name": "a"}]})") ==
        f + ": set: expected array, got string");
  CHECK(load(R"({"run_config": "x", "budgets": [5], "points": [{"name": "a", "sets": []}]})") ==
        f + ": points[0].sets: unknown key");
  CHECK(load(R"({"run_config": "x", "budget": [5], "points": [{"name": "a"}]})") ==
        f + ": budgets: needs at least one training budget");
  CHECK(load(R"({"run_config": "x", "budgets": [5], "points": [{"name": "a"}], "raster": {"n": []}})") ==
        f + ": raster.n: unknown key");
}

TEST_CASE("sweep files: child processes report exit status, signals and peak memory") {
  const std::string log = scratch("child.log");
  auto ok = handscs::run_process({"sh", "-c", "echo hello; echo oops >&2"}, log);
  CHECK(ok.exit_code == 0);
  CHECK(handscs::read_file(log) == "hello\noops\n");
  CHECK(ok.wall_seconds >= 0.0);
  CHECK(ok.wall_seconds < 60.0);
  CHECK(handscs::run_process({"sh", "-c", "exit 3"}, log).exit_code == 3);
  CHECK(handscs::run_process({"sh", "-c", "kill -9 $$"}, log).exit_code == 128 + 9);
  // A child that touches 200 MiB has at least that much peak resident memory, and it is the
  // child's figure: this test process itself is far smaller.
  auto big = handscs::run_process(
      {"/usr/bin/python3", "-c", "b = bytearray(200 * 1024 * 1024); b[::4096] = b'x' * len(b[::4096])"},
      log);
  CHECK(big.exit_code == 0);
  CHECK(big.peak_rss_mb > 200.0);
  CHECK(big.peak_rss_mb < 400.0);
  CHECK(error_of([&] { handscs::run_process({"/nonexistent/handscs-nothing"}, log); }) ==
        "/nonexistent/handscs-nothing: cannot run (No such file or directory)");
  CHECK(error_of([&] { handscs::run_process({"true"}, "/nonexistent/dir/x.log"); }) ==
        "/nonexistent/dir/x.log: cannot create log file (No such file or directory)");
}

TEST_CASE("sweep files: CSV tables round-trip quoted cells and refuse ragged rows") {
  handscs::CsvTable table;
  table.header = {"point", "settings", "psnr"};
  table.rows = {{"default", "(run config)", "31.2"},
                {"lr", "train.lr.means=1e-3 \"x\", y", ""}};
  const std::string path = scratch("t.csv");
  handscs::write_csv_atomic(path, table);
  const auto back = handscs::read_csv(path);
  CHECK(back.header == table.header);
  CHECK(back.rows == table.rows);
  CHECK(back.at(1, "settings") == "train.lr.means=1e-3 \"x\", y");
  CHECK(back.column("psnr") == 2);
  CHECK(back.column("nope") == -1);
  CHECK(error_of([&] { back.at(0, "nope"); }) == "CSV: no column \"nope\"");
  const std::string ragged = write("ragged.csv", "a,b\n1,2\n3\n");
  CHECK(error_of([&] { handscs::read_csv(ragged); }) == ragged + ":3: 1 cells, the header has 2");
  const std::string open = write("open.csv", "a,b\n\"1,2\n");
  CHECK(error_of([&] { handscs::read_csv(open); }) == open + ":2: unterminated quoted cell");
}
