// The handscs-eval executable (built to HANDSCS_BIN_DIR): folder mode on the shared pairs, the
// LPIPS-skipped message, the exit status for failures and for bad options.
#include "metrics_test_utils.h"  // first: brings Catch2 in after torch (see there)

#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>

#include <nlohmann/json.hpp>

#include "core/atomic_file.h"

namespace {

using metrics_test::run_eval;

size_t count(const std::string& text, const std::string& what) {
  size_t n = 0;
  for (size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

}  // namespace

TEST_CASE("handscs-eval folder mode scores the shared pairs and writes JSON and CSV", "[eval][cli]") {
  const auto dir = metrics_test::temp_dir("eval_cli");
  const auto pairs = metrics_test::pairs_dir();
  const auto run = run_eval("--pred " + pairs + "/dist --gt " + pairs + "/ref --lpips-weights " +
                                metrics_test::lpips_alex_path() + " --json " + dir + "/out.json --csv " +
                                dir + "/out.csv",
                            dir);
  INFO(run.output);
  CHECK(run.status == 0);
  CHECK(run.output.find("I03          21.114  0.68190  0.72370") != std::string::npos);
  CHECK(run.output.find("mean (2)") != std::string::npos);
  const auto j = nlohmann::json::parse(handscs::read_file(dir + "/out.json"));
  CHECK(j["summary"]["scored"] == 2);
  CHECK(j["summary"]["lpips"].get<double>() == Approx((0.7237 + 0.2572) / 2).margin(1e-4));
  CHECK(std::filesystem::exists(dir + "/out.csv"));
}

TEST_CASE("handscs-eval without LPIPS weights says so once and reports null", "[eval][cli]") {
  const auto dir = metrics_test::temp_dir("eval_cli_nolpips");
  const auto pairs = metrics_test::pairs_dir();
  const auto run = run_eval("--pred " + pairs + "/dist --gt " + pairs + "/ref --ssim valid --json " + dir +
                                "/out.json",
                            dir);
  INFO(run.output);
  CHECK(run.status == 0);
  CHECK(count(run.output, "LPIPS skipped, reported as null: no LPIPS weight file given") == 1);
  const auto j = nlohmann::json::parse(handscs::read_file(dir + "/out.json"));
  CHECK(j["summary"]["lpips"].is_null());
  CHECK(j["config"]["ssim"]["variant"] == "valid");
}

TEST_CASE("handscs-eval exits 2 when some images fail and 1 on bad options", "[eval][cli]") {
  const auto dir = metrics_test::temp_dir("eval_cli_fail");
  handscs::ensure_directory(dir + "/pred");
  const auto pairs = metrics_test::pairs_dir();
  std::filesystem::copy_file(pairs + "/dist/I03.bmp", dir + "/pred/I03.bmp");  // temp copy, I04 missing
  auto run = run_eval("--pred " + dir + "/pred --gt " + pairs + "/ref --json " + dir + "/out.json", dir);
  INFO(run.output);
  CHECK(run.status == 2);
  CHECK(run.output.find("1 of 2 images failed and are excluded from the means:") != std::string::npos);
  CHECK(run.output.find("I04: no prediction in " + dir + "/pred") != std::string::npos);
  run = run_eval("--pred " + dir + "/pred --gt " + pairs + "/ref --ssim gauss --json " + dir + "/o.json", dir);
  CHECK(run.status == 1);
  CHECK(run.output.find("command line: ssim.variant: unknown value \"gauss\" (known: 3dgs, valid, matlab)") !=
        std::string::npos);
  run = run_eval("--pred " + dir + "/pred --gt " + pairs + "/ref", dir);
  CHECK(run.status == 1);
  CHECK(run.output.find("folder mode needs --json FILE for the results") != std::string::npos);
  run = run_eval("--pred " + dir + "/pred --gt " + pairs + "/ref --lpips-weights " + dir +
                     "/missing.pt --json " + dir + "/o.json",
                 dir);
  CHECK(run.status == 1);
  CHECK(run.output.find(dir + "/missing.pt: cannot open file") != std::string::npos);
  CHECK_FALSE(std::filesystem::exists(dir + "/o.json"));
  // Options of the other mode are errors, never ignored.
  run = run_eval("--pred " + dir + "/pred --gt " + pairs + "/ref --json " + dir + "/o.json --out " + dir +
                     "/o --max-images 3",
                 dir);
  CHECK(run.status == 1);
  CHECK(run.output.find("--out, --max-images: model-mode option(s), used only with --checkpoint") !=
        std::string::npos);
  run = run_eval("--checkpoint " + dir + "/run --out " + dir + "/o --json " + dir + "/o.json", dir);
  CHECK(run.status == 1);
  CHECK(run.output.find("--json: folder-mode option(s), not used with --checkpoint") != std::string::npos);
  run = run_eval("--checkpoint " + dir + "/run --out " + dir + "/o --max-images -1", dir);
  CHECK(run.status != 0);
  CHECK(run.output.find("--max-images: Value -1 not in range 0 to 100000000") != std::string::npos);
  CHECK_FALSE(std::filesystem::exists(dir + "/o.json"));
}
