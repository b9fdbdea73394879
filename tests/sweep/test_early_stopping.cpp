// scripts/early_stopping.py, the fair baseline of the scaling study's few-pose cell: a run trained on
// the tiny capture with two validation poses and every checkpoint kept, checked against references
// worked out here: each checkpoint's validation PSNR is the mean of its images' PSNRs over the last
// two training poses' frames (none of them a test frame), the choice is the brute-force best, and
// the test scores of the chosen and the last checkpoint equal handscs-eval's own scores of them, run
// here. Then paired_gains.py reads the output as a sweep, a second call scores nothing again, a
// sweep with no validation run is refused, and the choice itself keeps the earlier of a tie and
// never picks a checkpoint whose PSNR is not finite (hand-made scores).
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <string>

#include <nlohmann/json.hpp>

#include "core/atomic_file.h"
#include "core/csv_table.h"
#include "test_support.h"

using handscs_test::kBin;
using handscs_test::kSource;

namespace {

int run(const std::string& command, const std::string& log) {
  return std::system((command + " > '" + log + "' 2>&1").c_str());
}

nlohmann::json summary_of(const std::string& eval_dir) {
  std::ifstream in(eval_dir + "/summary.json");
  return nlohmann::json::parse(in);
}

// The image names of an evaluation's per_image.csv, and the mean of their PSNRs.
std::set<std::string> images_of(const std::string& eval_dir, double* mean_psnr = nullptr) {
  const auto table = handscs::read_csv(eval_dir + "/per_image.csv");
  std::set<std::string> names;
  double sum = 0;
  for (size_t r = 0; r < table.rows.size(); ++r) {
    names.insert(table.at(r, "name"));
    sum += std::stod(table.at(r, "psnr"));
  }
  if (mean_psnr) *mean_psnr = sum / table.rows.size();
  return names;
}

}  // namespace

TEST_CASE("early_stopping.py: the best validation checkpoint and the last, scored on the test poses") {
  const std::string dir = handscs_test::scratch_path("handscs_test_early_stopping", std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir + "/sweep/runs");
  const std::string log = dir + "/log.txt", capture = dir + "/capture";
  REQUIRE(run(kBin + "/handscs-synth --preset tiny --threads 1 --log-level warn --out " + capture, log) == 0);
  // 12 poses: the last 3 held out (tests), the 2 before them validation, 7 to train on.
  const std::string train = kBin + "/handscs-train --config " + kSource + "/configs/tiny.json --threads 1 " +
                            "--log-level warn --set data.root=" + capture + " train.iterations=30 " +
                            "train.checkpoint_every=10 train.keep_checkpoints=0 train.validate_every=0 ";
  const std::string run_dir = dir + "/sweep/runs/full.p7v2.s0_30";
  REQUIRE(run(train + "data.validation_poses=2 --out " + run_dir, log) == 0);
  REQUIRE(run(train + "train.iterations=10 --out " + dir + "/sweep/runs/plain.p9.s0_10", log) == 0);
  const std::string ckpt = run_dir + "/checkpoints/step_000000";
  handscs::write_file_atomic(dir + "/sweep/results.csv",
                             "point,budget,status\nfull.p7v2.s0,30,ok\nplain.p9.s0,10,ok\n");

  const std::string lpips = handscs_test::kLpipsAlexWeights;
  const std::string script = "/usr/bin/python3 '" + kSource + "/scripts/early_stopping.py' --bin " + kBin;
  const std::string out = dir + "/out";
  const std::string call = script + " --lpips-weights " + lpips + " --out " + out + " " + dir + "/sweep";
  REQUIRE(run(call, log) == 0);
  CHECK(handscs::read_file(log).find("plain.p9.s0_10: trained without data.validation_poses; left out") !=
        std::string::npos);

  // Every checkpoint's validation PSNR: the mean over the validation images, frames of the two
  // poses before the held-out ones.
  const auto validation = handscs::read_csv(out + "/validation.csv");
  REQUIRE(validation.rows.size() == 3);
  std::map<int, double> psnr;
  std::set<std::string> validation_images;
  for (size_t r = 0; r < validation.rows.size(); ++r) {
    const int step = std::stoi(validation.at(r, "step"));
    psnr[step] = std::stod(validation.at(r, "psnr"));
    double mean = 0;
    const auto images = images_of(run_dir + "/early_stopping/validation_" + std::to_string(step), &mean);
    CHECK(images.size() == 8);  // 2 poses x 4 cameras
    CHECK(std::abs(mean - psnr[step]) < 1e-4);
    validation_images.insert(images.begin(), images.end());
  }
  CHECK(validation_images.size() == 8);  // the same images for every checkpoint
  int best = -1;
  for (const auto& [step, value] : psnr)
    if (best < 0 || value > psnr.at(best)) best = step;

  const auto results = handscs::read_csv(out + "/results.csv");
  REQUIRE(results.rows.size() == 2);
  REQUIRE(results.at(0, "point") == "full_es.p7v2.s0");
  REQUIRE(results.at(1, "point") == "full_end.p7v2.s0");
  CHECK(results.at(0, "step") == std::to_string(best));
  CHECK(results.at(1, "step") == "30");
  CHECK(results.at(0, "status") == "ok");
  CHECK(results.at(1, "eval_images") == "12");  // 3 held-out poses x 4 cameras

  // The test scores equal handscs-eval's of the checkpoints they copy, on the held-out poses.
  const std::string eval = kBin + "/handscs-eval --threads 1 --log-level warn --lpips-weights " + lpips +
                           " --set data.validation_poses=0 --checkpoint ";
  for (const auto& [point, source] : std::map<std::string, int>{{"full_es", best}, {"full_end", 30}}) {
    const std::string own = dir + "/own_" + point;
    REQUIRE(run(eval + ckpt + std::to_string(source) + ".ckpt --out " + own, log) == 0);
    const std::string scored = out + "/runs/" + point + ".p7v2.s0_30/eval";
    for (const char* metric : {"psnr", "ssim", "lpips"})
      CHECK(summary_of(scored)["summary"][metric].get<double>() ==
            Approx(summary_of(own)["summary"][metric].get<double>()).epsilon(1e-12));
    const auto test_images = images_of(scored);
    CHECK(test_images == images_of(own));
    CHECK(test_images.size() == 12);
    for (const auto& name : test_images) CHECK(validation_images.count(name) == 0);
  }

  // paired_gains.py reads the output as a sweep.
  REQUIRE(run("/usr/bin/python3 '" + kSource + "/scripts/paired_gains.py' " + out +
                  " --gain stop=full_es-full_end --out " + dir + "/gains",
              log) == 0);
  const auto gains = handscs::read_csv(dir + "/gains.csv");
  bool found = false;
  for (size_t r = 0; r < gains.rows.size(); ++r)
    if (gains.at(r, "gain") == "stop" && gains.at(r, "metric") == "psnr") {
      found = true;
      const double expected = summary_of(out + "/runs/full_es.p7v2.s0_30/eval")["summary"]["psnr"].get<double>() -
                              summary_of(out + "/runs/full_end.p7v2.s0_30/eval")["summary"]["psnr"].get<double>();
      CHECK(std::stod(gains.at(r, "mean")) == Approx(expected).margin(1e-4));
    }
  CHECK(found);

  // A second call scores nothing again: the summaries keep their times, the results their text.
  const auto stamp = std::filesystem::last_write_time(out + "/runs/full_es.p7v2.s0_30/eval/summary.json");
  const auto validation_stamp =
      std::filesystem::last_write_time(run_dir + "/early_stopping/validation_10/summary.json");
  const std::string before = handscs::read_file(out + "/results.csv");
  REQUIRE(run(call, log) == 0);
  CHECK(handscs::read_file(out + "/results.csv") == before);
  CHECK(std::filesystem::last_write_time(out + "/runs/full_es.p7v2.s0_30/eval/summary.json") == stamp);
  CHECK(std::filesystem::last_write_time(run_dir + "/early_stopping/validation_10/summary.json") ==
        validation_stamp);

  // A sweep with no run trained on validation poses is refused, and says why.
  handscs::write_file_atomic(dir + "/sweep/results.csv", "point,budget,status\nplain.p9.s0,10,ok\n");
  CHECK(run(script + " --out " + dir + "/none " + dir + "/sweep", log) != 0);
  CHECK(handscs::read_file(log).find("no kept run trained with validation poses and checkpoints") !=
        std::string::npos);
  std::filesystem::remove_all(dir);
}

TEST_CASE("early_stopping.py: the choice is the highest finite PSNR, the earlier of a tie") {
  const auto choice = [](const std::string& scores) {
    const std::string dir = handscs_test::scratch_path("handscs_test_early_stopping_choice", std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    const std::string command = "cd '" + kSource + "/scripts' && /usr/bin/python3 -c 'import early_stopping; "
                                "print(early_stopping.choose(" + scores + "))' > " + dir + "/choice.txt";
    REQUIRE(std::system(command.c_str()) == 0);
    const std::string text = handscs::read_file(dir + "/choice.txt");
    std::filesystem::remove_all(dir);
    return text;
  };
  CHECK(choice("[(10, 20.0), (20, 22.5), (30, 22.5), (40, 21.0)]") == "(20, 22.5)\n");  // tie: the earlier
  CHECK(choice("[(10, 20.0), (20, None), (30, 19.0)]") == "(10, 20.0)\n");            // None: not finite
  CHECK(choice("[(10, None)]") == "None\n");
}
