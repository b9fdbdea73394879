// sweep/sweep_shard.h: --shard and Slurm's array variables parse (bad values are errors naming
// them); for every n the shards partition the sweep's runs (each run exactly once, sizes within
// one); merging shards' results gives one row per run, a finished row over a failed attempt, and
// refuses duplicates, other columns and a foreign results.csv in the target.
#include <catch2/catch.hpp>

#include <cstdlib>
#include <filesystem>
#include <map>
#include <set>

#include "core/atomic_file.h"
#include "core/config.h"
#include "core/error.h"
#include "core/csv_table.h"
#include "sweep/sweep_shard.h"
#include "test_support.h"

namespace fs = std::filesystem;
using handscs_test::error_of;

namespace {

using handscs_test::kSource;
using handscs_test::ScopedEnv;
// The columns of results.csv as the version before resumed_from_step wrote them
// (sweep/results_table.cpp; the shards below are of that version unless they say otherwise).
const std::string kHeader =
    "point,budget,threads,settings,status,train_wall_s,loop_s,ms_per_step,peak_rss_mb,gaussians,"
    "skipped_steps,rollbacks,eval_images,psnr,ssim,lpips,eval_wall_s,render_fps,data_ms,forward_ms,"
    "losses_ms,backward_ms,optimizer_ms";

std::string row(const std::string& point, const std::string& status, const std::string& psnr) {
  return point + ",400,2,,"+ status + ",60,59,148,700,1700,0,0,60," + psnr +
         ",0.95,0.09,30,50,1,5,13,16,2";
}

std::string shard_dir(const std::string& name, const std::vector<std::string>& rows,
                      const std::string& header = kHeader) {
  const std::string dir = handscs_test::scratch_path("handscs_test_shard", name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  std::string text = header + "\n";
  for (const auto& r : rows) text += r + "\n";
  handscs::write_file_atomic(dir + "/results.csv", text);
  return dir;
}

}  // namespace

TEST_CASE("sweep shard: --shard i/n parses, anything else names the flag") {
  const auto s = handscs::parse_sweep_shard("2/4");
  CHECK(s.index == 2);
  CHECK(s.count == 4);
  CHECK(handscs::parse_sweep_shard("0/1").count == 1);
  for (const char* bad : {"4/4", "-1/3", "1/0", "a/2", "2", "", "1/2/3", "1 /2"}) {
    INFO(bad);
    CHECK(error_of([&] { handscs::parse_sweep_shard(bad); }) ==
          std::string("--shard ") + bad +
              ": expected i/n with 0 <= i < n (shard i of n, counted from 0), e.g. 0/4");
  }
}

TEST_CASE("sweep shard: a Slurm job array chooses the shard") {
  ::unsetenv("SLURM_ARRAY_TASK_ID");
  ::unsetenv("SLURM_ARRAY_TASK_MIN");
  ::unsetenv("SLURM_ARRAY_TASK_COUNT");
  CHECK(handscs::sweep_shard_from_environment().count == 1);
  {
    ScopedEnv id("SLURM_ARRAY_TASK_ID", "5"), min("SLURM_ARRAY_TASK_MIN", "3"),
        count("SLURM_ARRAY_TASK_COUNT", "4");
    const auto s = handscs::sweep_shard_from_environment();
    CHECK(s.index == 2);
    CHECK(s.count == 4);
  }
  {
    ScopedEnv id("SLURM_ARRAY_TASK_ID", "9"), count("SLURM_ARRAY_TASK_COUNT", "4");
    CHECK(error_of([] { handscs::sweep_shard_from_environment(); })
              .find("not a shard (expected MIN <= ID < MIN + COUNT)") != std::string::npos);
  }
}

TEST_CASE("sweep shard: the shards of every n partition the runs, balanced") {
  const auto config = handscs::load_sweep_config(kSource + "/configs/sweeps/full.json");
  const auto runs = handscs::sweep_runs(config, {});
  REQUIRE(runs.size() > 20);
  for (int n = 1; n <= 7; ++n) {
    INFO("n = " << n);
    std::map<std::pair<std::string, int>, int> count;
    size_t smallest = runs.size(), largest = 0;
    for (int i = 0; i < n; ++i) {
      const auto mine = handscs::shard_runs(runs, {i, n});
      smallest = std::min(smallest, mine.size());
      largest = std::max(largest, mine.size());
      for (const auto& [point, budget] : mine) ++count[{point->name, budget}];
    }
    CHECK(count.size() == runs.size());
    for (const auto& [run, times] : count) CHECK(times == 1);
    CHECK(largest - smallest <= 1);
  }
  // --points narrows the enumeration before sharding; an unknown name is an error.
  CHECK(handscs::sweep_runs(config, {config.points.front().name}).size() >= 1);
  CHECK(error_of([&] { handscs::sweep_runs(config, {"nope"}); })
            .find("--points names \"nope\", which is not a point") != std::string::npos);
}

TEST_CASE("sweep shard: merging gives one row per run, finished rows over failed attempts") {
  const std::string a = shard_dir("a", {row("p.s0", "ok", "30.1"), row("q.s0", "failed", "")});
  const std::string b = shard_dir("b", {row("q.s0", "ok", "29.5"), row("r.s0", "ok", "31.0")});
  const std::string out = handscs_test::scratch_path("handscs_test_shard", "merged");
  fs::remove_all(out);
  handscs::merge_sweep_shards(out, {a, b});
  const auto merged = handscs::read_csv(out + "/results.csv");
  REQUIRE(merged.rows.size() == 3);
  std::map<std::string, std::string> psnr;
  for (size_t r = 0; r < merged.rows.size(); ++r) {
    CHECK(merged.at(r, "status") == "ok");
    psnr[merged.at(r, "point")] = merged.at(r, "psnr");
  }
  CHECK(psnr == std::map<std::string, std::string>{{"p.s0", "30.1"}, {"q.s0", "29.5"}, {"r.s0", "31.0"}});
  CHECK(fs::exists(out + "/summary.md"));

  // Merging again into the same folder is refused: it is not one of the shards.
  CHECK(error_of([&] { handscs::merge_sweep_shards(out, {a, b}); }) ==
        out + "/results.csv exists and is not one of the shards: merge into a new folder (nothing "
              "is overwritten or mixed without being asked)");
  // Into one of the shards is allowed.
  handscs::merge_sweep_shards(a, {a, b});
  CHECK(handscs::read_csv(a + "/results.csv").rows.size() == 3);
}

TEST_CASE("sweep shard: a shard of the version before resumed_from_step merges with one of today's") {
  const std::string a = shard_dir("before", {row("p.s0", "ok", "30.1")});
  const std::string b = shard_dir("today", {row("q.s0", "ok", "29.5") + ",2000"},
                                  kHeader + ",resumed_from_step");
  const std::string out = handscs_test::scratch_path("handscs_test_shard", "versions");
  fs::remove_all(out);
  handscs::merge_sweep_shards(out, {a, b});
  const auto merged = handscs::read_csv(out + "/results.csv");
  CHECK(merged.header.back() == "resumed_from_step");
  REQUIRE(merged.rows.size() == 2);
  CHECK(merged.at(0, "point") == "p.s0");
  CHECK(merged.at(0, "resumed_from_step").empty());
  CHECK(merged.at(1, "resumed_from_step") == "2000");
  CHECK(merged.at(1, "psnr") == "29.5");
}

TEST_CASE("sweep shard: duplicate finished runs and other columns are refused") {
  const std::string a = shard_dir("dup_a", {row("p.s0", "ok", "30.1")});
  const std::string b = shard_dir("dup_b", {row("p.s0", "ok", "30.2")});
  const std::string out = handscs_test::scratch_path("handscs_test_shard", "dup_out");
  fs::remove_all(out);
  CHECK(error_of([&] { handscs::merge_sweep_shards(out, {a, b}); }) ==
        b + "/results.csv and " + a + "/results.csv both hold a finished run of p.s0 at budget 400: "
            "were two shards given the same --shard?");
  const std::string other = shard_dir("dup_other", {"p.s0,400"}, "point,budget");
  CHECK(error_of([&] { handscs::merge_sweep_shards(out, {a, other}); }) ==
        other + "/results.csv: not a results.csv of this version or the one before; its columns "
                "differ from " + kHeader + ",resumed_from_step");
  CHECK(error_of([&] { handscs::merge_sweep_shards(out, {a, out + "_missing"}); }) ==
        out + "_missing/results.csv: not found (is " + out + "_missing a shard's --out folder?)");
  CHECK_FALSE(fs::exists(out + "/results.csv"));
}

TEST_CASE("sweep shard: shard records refuse another sweep, another split, a shard twice or missing") {
  const auto with_record = [](const std::string& name, const std::string& run, const std::string& sweep,
                              const std::string& fingerprint, int index, int count) {
    const std::string dir = shard_dir(name, {run});
    handscs::write_shard_record(dir, {sweep, fingerprint, {index, count}});
    return dir;
  };
  const std::string one = "00000000000000aa";
  const std::string a = with_record("rec_a", row("p.s0", "ok", "30.1"), "sweep.json", one, 0, 2);
  const std::string b = with_record("rec_b", row("q.s0", "ok", "29.5"), "sweep.json", one, 1, 2);
  const std::string out = handscs_test::scratch_path("handscs_test_shard", "rec_out");
  fs::remove_all(out);
  handscs::merge_sweep_shards(out, {a, b});
  CHECK(handscs::read_csv(out + "/results.csv").rows.size() == 2);
  const auto merged = handscs::load_json_file(out + "/shard.json");
  CHECK(merged["fingerprint"] == one);
  CHECK(merged["shard"] == 0);
  CHECK(merged["shards"] == 1);  // the merged folder holds the whole sweep

  const std::string none = handscs_test::scratch_path("handscs_test_shard", "rec_refused");
  fs::remove_all(none);
  const std::string other =
      with_record("rec_other", row("r.s0", "ok", "31.0"), "other.json", "00000000000000bb", 1, 2);
  CHECK(error_of([&] { handscs::merge_sweep_shards(none, {a, other}); }) ==
        other + " and " + a + " hold shards of different sweeps (other.json, sweep.json): merge "
                              "the shards of one sweep");
  CHECK(error_of([&] { handscs::merge_sweep_shards(none, {a}); }) ==
        "merge: shard 1 of 2 (counted from 0) not given: the table would miss their runs; give every "
        "shard's folder");
  const std::string twice = with_record("rec_twice", row("q.s0", "failed", ""), "sweep.json", one, 0, 2);
  CHECK(error_of([&] { handscs::merge_sweep_shards(none, {a, twice}); }) ==
        twice + " and " + a + " are both shard 0: were two machines given the same --shard?");
  const std::string thirds = with_record("rec_thirds", row("q.s0", "ok", "29.5"), "sweep.json", one, 1, 3);
  CHECK(error_of([&] { handscs::merge_sweep_shards(none, {a, thirds}); }) ==
        thirds + " is shard 1 of 3, " + a + " one of 2: merge the shards of one split");
  const std::string older = shard_dir("rec_older", {row("q.s0", "ok", "29.5")});
  CHECK(error_of([&] { handscs::merge_sweep_shards(none, {a, older}); }) ==
        older + "/shard.json: not found, while the other folders have one: is " + older +
            " a shard of this sweep?");
  CHECK_FALSE(fs::exists(none + "/results.csv"));
}

TEST_CASE("sweep shard: a sweep's fingerprint follows its file's bytes and the points chosen") {
  const std::string dir = handscs_test::scratch_path("handscs_test_shard", "fingerprint");
  fs::remove_all(dir);
  fs::create_directories(dir);
  handscs::SweepConfig config;
  config.path = dir + "/sweep.json";
  handscs::write_file_atomic(config.path, "{\"budgets\": [100]}\n");
  const auto first = handscs::shard_record(config, {}, {0, 2});
  CHECK(first.fingerprint.size() == 16);
  CHECK(first.sweep == config.path);
  CHECK(handscs::shard_record(config, {}, {1, 2}).fingerprint == first.fingerprint);
  CHECK(handscs::shard_record(config, {"p"}, {0, 2}).fingerprint != first.fingerprint);
  handscs::write_file_atomic(config.path, "{\"budgets\": [200]}\n");
  CHECK(handscs::shard_record(config, {}, {0, 2}).fingerprint != first.fingerprint);
}
