// tools/study/capture_factor.py, a gain with the capture as a factor: per capture the paired gain's
// mean and sample std and the study's rule, across captures the mean and std of the per-capture
// means and the declared reading; written sweeps with known figures, and the published novel-view
// gains read back from docs/bench.
#include <catch2/catch.hpp>

#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <string>

#include "core/atomic_file.h"
#include "test_support.h"

namespace {

// Made at first use, under the test process's own temp folder (tests/main.cpp sets it in main).
const std::string& scratch() {
  static const std::string dir =
      handscs_test::scratch_path("handscs_test_capture_factor", std::to_string(::getpid()));
  return dir;
}

// A results.csv of rows "point,psnr,ssim,lpips" at 10,000 steps, status ok.
std::string sweep(const std::string& name, const std::vector<std::tuple<std::string, double, double, double>>& rows) {
  const std::string folder = scratch() + "/" + name;
  std::filesystem::create_directories(folder);
  std::string csv = "point,budget,status,psnr,ssim,lpips\n";
  for (const auto& [point, psnr, ssim, lpips] : rows)
    csv += point + ",10000,ok," + std::to_string(psnr) + "," + std::to_string(ssim) + "," + std::to_string(lpips) + "\n";
  handscs::write_file_atomic(folder + "/results.csv", csv);
  return folder;
}

std::string run(const std::string& arguments) {
  const std::string out = scratch() + "/out.txt";
  const std::string command = "/usr/bin/python3 " + handscs_test::kSource + "/tools/study/capture_factor.py " +
                              arguments + " > '" + out + "' 2>&1";
  const int status = std::system(command.c_str());
  const std::string text = handscs::read_file(out);
  INFO(text);
  REQUIRE(status == 0);
  return text;
}

// The declared capture-factor reading of `gain` from docs/bench: the study's capture (its sweep's
// CSV) and the two captures synthesised with seeds 2 and 3 (`cell`'s CSVs, e.g. "scaling_view_captures").
std::string across_three_captures(const std::string& study_csv, const std::string& gain,
                                  const std::string& cell = "scaling_view_captures", const std::string& options = "") {
  const std::string bench = handscs_test::kSource + "/docs/bench/";
  return run("--capture seed1=" + bench + study_csv + " --capture seed2=" + bench + cell + "_rp2.csv --capture seed3=" +
             bench + cell + "_rp3.csv --gain " + gain + " " + options);
}

}  // namespace

TEST_CASE("capture_factor.py: per-capture gains, their rule, and the reading across captures") {
  // Capture A: full - c = +0.2, +0.1, +0.3 (mean 0.2, std 0.1): pays. Capture B: +0.1, -0.1, +0.3
  // (mean 0.1, std 0.2): no difference shown. Across: mean 0.15, std 0.0707.
  const std::string a = sweep("A", {{"c.view.s10", 30.0, 0.95, 0.05}, {"full.view.s10", 30.2, 0.96, 0.04},
                                    {"c.view.s11", 31.0, 0.95, 0.05}, {"full.view.s11", 31.1, 0.95, 0.05},
                                    {"c.view.s12", 32.0, 0.95, 0.05}, {"full.view.s12", 32.3, 0.95, 0.05}});
  const std::string b = sweep("B", {{"c.view.s10", 30.0, 0.9, 0.1}, {"full.view.s10", 30.1, 0.9, 0.1},
                                    {"c.view.s11", 30.0, 0.9, 0.1}, {"full.view.s11", 29.9, 0.9, 0.1},
                                    {"c.view.s12", 30.0, 0.9, 0.1}, {"full.view.s12", 30.3, 0.9, 0.1}});
  std::string text = run("--capture A=" + a + " --capture B=" + b + " --gain scs=full-c --out " + scratch() + "/table");
  CHECK_THAT(text, Catch::Contains("| A | s10 +0.200 / s11 +0.100 / s12 +0.300 | +0.200 ± 0.100 | pays | +0.0033 | -0.0033 |"));
  CHECK_THAT(text, Catch::Contains("| B | s10 +0.100 / s11 -0.100 / s12 +0.300 | +0.100 ± 0.200 | no difference shown |"));
  CHECK_THAT(text, Catch::Contains("Across 2 complete of 2 captures: mean of the per-capture means +0.150 ± 0.071 dB."));
  CHECK_THAT(text, Catch::Contains("Reading: **does not hold across captures: pays on 1 of 2**."));
  CHECK(handscs::read_file(scratch() + "/table.md") + "\n" == text);
  // Every capture paying holds; a capture short of a seed gives no verdict.
  text = run("--capture A=" + a + " --capture A_again=" + a + " --gain scs=full-c");
  CHECK_THAT(text, Catch::Contains("Reading: **holds across captures (pays on every capture)**."));
  const std::string short_of_one = sweep("C", {{"c.view.s10", 30.0, 0.9, 0.1}, {"full.view.s10", 30.5, 0.9, 0.1}});
  text = run("--capture A=" + a + " --capture C=" + short_of_one + " --gain scs=full-c");
  CHECK_THAT(text, Catch::Contains("| C | s10 +0.500 | +0.500 ± n/a | incomplete (1 of 3 seeds) |"));
  CHECK_THAT(text, Catch::Contains("Reading: **no verdict yet: 1 capture(s) incomplete**."));
}

TEST_CASE("capture_factor.py: \"no difference\" holds across captures only where no capture pays or costs") {
  // Capture N: +0.1, -0.1, +0.3 (no difference shown); capture P: +0.2, +0.1, +0.3 (pays); capture
  // C: -0.2, -0.1, -0.3 (costs). Cell p350, as the novel-pose cell names its points.
  const std::string n = sweep("N", {{"c.p350.s10", 30.0, 0.9, 0.1}, {"full.p350.s10", 30.1, 0.9, 0.1},
                                    {"c.p350.s11", 30.0, 0.9, 0.1}, {"full.p350.s11", 29.9, 0.9, 0.1},
                                    {"c.p350.s12", 30.0, 0.9, 0.1}, {"full.p350.s12", 30.3, 0.9, 0.1}});
  const std::string p = sweep("P", {{"c.p350.s10", 30.0, 0.9, 0.1}, {"full.p350.s10", 30.2, 0.9, 0.1},
                                    {"c.p350.s11", 30.0, 0.9, 0.1}, {"full.p350.s11", 30.1, 0.9, 0.1},
                                    {"c.p350.s12", 30.0, 0.9, 0.1}, {"full.p350.s12", 30.3, 0.9, 0.1}});
  const std::string c = sweep("C", {{"c.p350.s10", 30.0, 0.9, 0.1}, {"full.p350.s10", 29.8, 0.9, 0.1},
                                    {"c.p350.s11", 30.0, 0.9, 0.1}, {"full.p350.s11", 29.9, 0.9, 0.1},
                                    {"c.p350.s12", 30.0, 0.9, 0.1}, {"full.p350.s12", 29.7, 0.9, 0.1}});
  const std::string options = " --gain scs=full-c --cell p350 --holds none";
  std::string text = run("--capture N=" + n + " --capture N_again=" + n + options);
  CHECK_THAT(text, Catch::Contains("# Gains with the capture as a factor (p350 cell, 10000 steps)"));
  CHECK_THAT(text, Catch::Contains("Reading: **no difference holds across captures (no capture shows a gain or a cost)**."));
  text = run("--capture N=" + n + " --capture P=" + p + " --capture C=" + c + options);
  CHECK_THAT(text, Catch::Contains("| C | s10 -0.200 / s11 -0.100 / s12 -0.300 | -0.200 ± 0.100 | costs |"));
  CHECK_THAT(text, Catch::Contains("Reading: **no difference does not hold across captures: pays on 1, costs on 1 of 3**."));
}

TEST_CASE("capture_factor.py: the published novel-view gains read back from docs/bench") {
  const std::string bench = handscs_test::kSource + "/docs/bench/";
  const std::string text = run("--capture seed1=" + bench + "scaling_view_10000_tau003.csv," + bench +
                               "scaling_view_10000.csv --gain scs=full_tau003-inter_pose_tau003 "
                               "--gain embeddings=embedding-baseline");
  // docs/SCALING.md: SCS +0.229 ± 0.035 dB, the embeddings +1.553 ± 0.014 dB.
  CHECK_THAT(text, Catch::Contains("| +0.229 ± 0.035 | pays |"));
  CHECK_THAT(text, Catch::Contains("| +1.553 ± 0.014 | pays |"));
}

TEST_CASE("capture_factor.py: SCS across the three captures reads back from docs/bench") {
  const std::string text = across_three_captures("scaling_view_10000_tau003.csv", "scs=full_tau003-inter_pose_tau003");
  // docs/SCALING.md, "SCS across captures".
  CHECK_THAT(text, Catch::Contains("| +0.162 ± 0.085 | pays |"));
  CHECK_THAT(text, Catch::Contains("| +0.152 ± 0.025 | pays |"));
  CHECK_THAT(text, Catch::Contains("mean of the per-capture means +0.181 ± 0.042 dB"));
  CHECK_THAT(text, Catch::Contains("Reading: **holds across captures (pays on every capture)**."));
}

TEST_CASE("capture_factor.py: the embeddings across the three captures read back from docs/bench") {
  const std::string text = across_three_captures("scaling_view_10000.csv", "embeddings=embedding-baseline");
  // docs/SCALING.md, "The embeddings across captures".
  CHECK_THAT(text, Catch::Contains("| +1.553 ± 0.014 | pays |"));
  CHECK_THAT(text, Catch::Contains("| +1.554 ± 0.130 | pays |"));
  CHECK_THAT(text, Catch::Contains("| +1.706 ± 0.110 | pays |"));
  CHECK_THAT(text, Catch::Contains("mean of the per-capture means +1.604 ± 0.088 dB"));
  CHECK_THAT(text, Catch::Contains("Reading: **holds across captures (pays on every capture)**."));
}

TEST_CASE("capture_factor.py: SCS with 350 poses across the three captures reads back from docs/bench") {
  const std::string text = across_three_captures("scaling_pose_10000_tau003.csv", "scs=full_tau003-inter_pose_tau003",
                                                 "scaling_pose_captures", "--cell p350 --holds none");
  // docs/SCALING.md, "SCS with 350 poses across captures".
  CHECK_THAT(text, Catch::Contains("| -0.042 ± 0.047 | no difference shown |"));
  CHECK_THAT(text, Catch::Contains("| s10 -0.526 / s11 -0.354 / s12 -0.068 | -0.316 ± 0.231 | costs |"));
  CHECK_THAT(text, Catch::Contains("| s10 -0.216 / s11 -0.133 / s12 -0.124 | -0.158 ± 0.051 | costs |"));
  CHECK_THAT(text, Catch::Contains("mean of the per-capture means -0.172 ± 0.138 dB"));
  CHECK_THAT(text, Catch::Contains("Reading: **no difference does not hold across captures: pays on 0, costs on 2 of 3**."));
}
