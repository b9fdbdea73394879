// draw_sweep_plots on a hand-written results.csv: summary.md marks the rows on each Pareto front
// (worked out by hand below) and the three plots are written.
#include <catch2/catch.hpp>

#include <filesystem>
#include <sstream>
#include <string>

#include "core/atomic_file.h"
#include "sweep/sweep_runner.h"
#include "test_support.h"

namespace {

namespace fs = std::filesystem;

// The summary.md row of (point, budget), "" when there is none.
std::string summary_row(const std::string& summary, const std::string& point, const std::string& budget) {
  std::istringstream lines(summary);
  const std::string prefix = "| " + point + " | " + budget + " |";
  for (std::string line; std::getline(lines, line);)
    if (line.rfind(prefix, 0) == 0) return line;
  return "";
}

}  // namespace

TEST_CASE("sweep summary: rows on the PSNR and LPIPS Pareto fronts are marked, failed rows never") {
  const std::string folder = "handscs_test_sweep_summary";
  fs::remove_all(handscs_test::scratch_path(folder, ""));
  // a@100: cheapest, so on both fronts. a@200: best PSNR, on the PSNR front; b@100 (90 s) has a better
  // LPIPS than a@200 for less time, so a@200 is off the LPIPS front. b@100 is dominated in PSNR by
  // a@100 (cheaper and higher) but has the best LPIPS. c failed: its zeros must not count.
  const std::string csv = handscs_test::scratch_file(folder, "results.csv",
                             "point,budget,threads,settings,status,train_wall_s,ms_per_step,peak_rss_mb,"
                             "gaussians,skipped_steps,psnr,ssim,lpips\n"
                             "a,100,2,(run config),ok,60,50,500,1696,0,30.0,0.95,0.10\n"
                             "a,200,2,(run config),ok,120,50,500,1696,0,32.0,0.96,0.08\n"
                             "b,100,2,x=1,ok,90,80,600,1696,0,29.0,0.94,0.07\n"
                             "c,100,2,x=2,failed (exit 1),0,0,0,0,0,99,1,0\n");
  const std::string dir = fs::path(csv).parent_path().string();
  handscs::draw_sweep_plots(dir);
  const std::string summary = handscs::read_file(dir + "/summary.md");
  CHECK(summary_row(summary, "a", "100") ==
        "| a | 100 | 2 | 60 | 50 | 500 | 1696 | 0 | 30.0 | 0.95 | 0.10 | PSNR, LPIPS | (run config) |");
  CHECK(summary_row(summary, "a", "200") ==
        "| a | 200 | 2 | 120 | 50 | 500 | 1696 | 0 | 32.0 | 0.96 | 0.08 | PSNR | (run config) |");
  CHECK(summary_row(summary, "b", "100") ==
        "| b | 100 | 2 | 90 | 80 | 600 | 1696 | 0 | 29.0 | 0.94 | 0.07 | LPIPS | x=1 |");
  CHECK(summary_row(summary, "c", "100") ==
        "| c | 100 | 2 | 0 | 0 | 0 | 0 | 0 | 99 | 1 | 0 |  | failed (exit 1) |");
  CHECK(fs::file_size(dir + "/psnr_vs_time.png") > 0);
  CHECK(fs::file_size(dir + "/lpips_vs_time.png") > 0);
  CHECK_FALSE(fs::exists(dir + "/raster_ms_vs_n.png"));  // no raster.csv, no raster plot
}
