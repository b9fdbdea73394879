// draw_sweep_plots on a hand-written results.csv: summary.md and pareto.csv mark the rows on each
// Pareto front (worked out by hand below), and matplotlib (scripts/plot_sweep.py) draws the charts
// as PNG and PDF.
#include <catch2/catch.hpp>

#include <filesystem>
#include <set>
#include <sstream>
#include <string>

#include "core/atomic_file.h"
#include "core/csv_table.h"
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

// True when the file exists and begins with `magic` (PNG and PDF signatures).
bool starts_with_bytes(const std::string& path, const std::string& magic) {
  if (!fs::exists(path)) return false;
  return handscs::read_file(path).compare(0, magic.size(), magic) == 0;
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
  const auto pareto = handscs::read_csv(dir + "/pareto.csv");
  std::set<std::string> on_front;
  for (size_t r = 0; r < pareto.rows.size(); ++r)
    on_front.insert(pareto.at(r, "metric") + " " + pareto.at(r, "point") + "@" + pareto.at(r, "budget"));
  CHECK(on_front == std::set<std::string>{"psnr a@100", "psnr a@200", "lpips a@100", "lpips b@100"});
  for (const char* chart : {"psnr_vs_time", "lpips_vs_time"}) {
    INFO(chart << " (see " << dir << "/logs/plots.log)");
    CHECK(starts_with_bytes(dir + "/" + chart + ".png", "\x89PNG"));
    CHECK(starts_with_bytes(dir + "/" + chart + ".pdf", "%PDF"));
  }
  CHECK_FALSE(fs::exists(dir + "/raster_ms_vs_n.png"));  // no raster.csv, no raster chart

  handscs_test::scratch_file(folder, "raster.csv",
                             "gaussians,threads,forward_ms,backward_ms,total_ms,load_average\n"
                             "1000,1,1.0,2.0,3.0,0.1\n10000,1,5.0,9.0,14.0,0.1\n"
                             "1000,2,0.6,1.1,1.7,0.1\n10000,2,3.0,5.0,8.0,0.1\n");
  handscs::draw_sweep_plots(dir);
  CHECK(starts_with_bytes(dir + "/raster_ms_vs_n.png", "\x89PNG"));
  CHECK(starts_with_bytes(dir + "/raster_ms_vs_n.pdf", "%PDF"));
  CHECK(handscs::read_file(dir + "/summary.md").find("| 10000 | 2 | 3.0 | 5.0 | 8.0 |") !=
        std::string::npos);
}
