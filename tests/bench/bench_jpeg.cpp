// handscs-bench-jpeg: the per-image checks a capture open runs on every JPEG, one image at a time
// on one thread (the open spreads images over threads): the damage check (core/jpeg_damage.h:
// libjpeg's 1/8-scale decode with its warnings) and the whole scan_image (read, damage check, black
// / monochrome tests on the check's 1/8 decode). Prints one JSON object with the median ms per
// image of each file. Default files: the four InterHand2.6M samples in ../shared/testdata (as read
// in place by the tests). --check-only runs the damage check alone, so that `perf stat -e
// instructions:u` at two repeat counts gives its instructions per image (difference over difference).
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "bench_timing.h"
#include "core/atomic_file.h"
#include "core/cli.h"
#include "core/jpeg_damage.h"
#include "core/logging.h"
#include "core/threads.h"
#include "data/image_checks.h"

int main(int argc, char** argv) {
  handscs::log_to_stderr();  // stdout carries the JSON only
  CLI::App app{"handscs-bench-jpeg: the JPEG checks a capture open runs per image"};
  handscs::CommonOptions common;
  handscs::add_common_options(app, common, false);
  const std::string samples = std::string(HANDSCS_SHARED_DIR) + "/testdata/interhand2.6m/";
  std::vector<std::string> files = {samples + "image2017.jpg", samples + "image29590.jpg",
                                    samples + "image44669.jpg", samples + "image69148.jpg"};
  int repeats = 200;
  bool check_only = false;
  app.add_option("files", files, "JPEG files (default: the InterHand2.6M samples of ../shared/testdata)");
  app.add_option("--repeats", repeats, "timed runs per file and check (median)")->capture_default_str();
  app.add_flag("--check-only", check_only, "time the damage check alone (for instruction counts)");
  CLI11_PARSE(app, argc, argv);
  try {
    handscs::start_up(common, "handscs-bench-jpeg");
    handscs::set_threads(1);  // one image at a time, as each of the open's threads checks one
    nlohmann::json out;
    out["bench"] = "jpeg";
    out["repeats"] = repeats;
    for (const auto& path : files) {
      const std::string bytes = handscs::read_file(path);
      std::vector<double> check, scan;
      const std::string problem = handscs::jpeg_damage(bytes);
      for (int r = 0; r < repeats + 3; ++r) {  // three warm-up runs
        const double check_ms = bench::ms_of([&] { (void)handscs::jpeg_damage(bytes); });
        const double scan_ms = check_only ? 0.0 : bench::ms_of([&] { (void)handscs::scan_image(path); });
        if (r < 3) continue;
        check.push_back(check_ms);
        if (!check_only) scan.push_back(scan_ms);
      }
      out["files"].push_back({{"file", path},
                              {"bytes", bytes.size()},
                              {"problem", problem},
                              {"damage_check_ms", bench::median(check)},
                              {"scan_image_ms", bench::median(scan)}});
    }
    std::printf("%s\n", out.dump(2).c_str());
    return 0;
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
}
