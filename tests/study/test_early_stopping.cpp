// tools/study/early_stopping.py, the fair baseline of the scaling study's few-pose cell. First with a
// stand-in handscs-eval that reports PSNRs chosen here and logs its calls: the choice is the best
// validation PSNR (the earlier of a tie, never a non-finite one), the chosen and the last checkpoint
// are scored on the test poses with the right options (once when they are the same), runs that cannot
// stop early are named and left out, a second call scores again only a checkpoint file that changed,
// and a novel-view run's validation cameras are emptied (not its validation poses) for the test. Then end to end on the tiny capture: each checkpoint's validation PSNR is the mean of its
// images' PSNRs over the last two training poses' frames (none of them a test frame, no LPIPS), the
// choice is the brute-force best, the test scores equal handscs-eval's own scores of those
// checkpoints, and paired_gains.py reads the output as a sweep.
#include <catch2/catch.hpp>

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

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

// A stand-in handscs-eval: logs its arguments to calls.txt and writes a summary whose PSNR is the
// checkpoint's line in psnr.txt ("PATH PSNR") for a validation score, 30 + step / 100 for a test
// score (data.validation_poses=0 or data.validation_cameras=[]).
void write_fake_eval(const std::string& dir) {
  std::filesystem::create_directories(dir + "/bin");
  const std::string program = dir + "/bin/handscs-eval";
  handscs::write_file_atomic(program, "#!/bin/bash\nargs=\"$*\"; out=; ckpt=\n"
                             "while [ $# -gt 0 ]; do case \"$1\" in --out) out=$2; shift ;; "
                             "--checkpoint) ckpt=$2; shift ;; esac; shift; done\n"
                             "echo \"$args\" >> '" + dir + "/calls.txt'\n"
                             "step=$(basename \"$ckpt\" .ckpt); step=$((10#${step#step_}))\n"
                             "case \"$args\" in *data.validation_poses=0*|*data.validation_cameras=[[]]*) "
                             "psnr=$((3000 + step))e-2 ;;\n"
                             "  *) psnr=$(awk -v c=\"$ckpt\" '$1 == c {print $2}' '" + dir + "/psnr.txt') ;; esac\n"
                             "psnr=${psnr:-\\\"missing\\\"}\n"
                             "mkdir -p \"$out\"\n"
                             "echo \"{\\\"inputs\\\": {}, \\\"summary\\\": {\\\"psnr\\\": $psnr, \\\"ssim\\\": 0.9, \\\"scored\\\": 12}}\" "
                             "> \"$out/summary.json\"\n");
  std::filesystem::permissions(program, std::filesystem::perms::owner_all);
}

// A kept run folder: config.json (without train.keep_checkpoints when it is negative, as builds
// before the key wrote it) and empty checkpoint files at `steps`.
void write_run(const std::string& run, int validation_poses, int keep_checkpoints, const std::vector<int>& steps) {
  std::filesystem::create_directories(run + "/checkpoints");
  handscs::write_file_atomic(run + "/config.json",
                             "{\"data\": {\"validation_poses\": " + std::to_string(validation_poses) +
                                 "}, \"train\": {" +
                                 (keep_checkpoints < 0 ? "" : "\"keep_checkpoints\": " + std::to_string(keep_checkpoints)) +
                                 "}}");
  for (int step : steps) {
    char name[32];
    std::snprintf(name, sizeof(name), "/step_%08d.ckpt", step);
    handscs::write_file_atomic(run + "/checkpoints" + name, "");
  }
}

std::vector<std::string> lines_of(const std::string& path) {
  std::istringstream in(handscs::read_file(path));
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

}  // namespace

TEST_CASE("early_stopping.py: the choice, the test scores and the runs left out, with a stand-in eval") {
  const std::string dir = handscs_test::scratch_path("handscs_test_early_stopping_fake", std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  write_fake_eval(dir);
  const std::string runs = dir + "/sweep/runs/";
  write_run(runs + "full.p2v1.s0_40", 1, 0, {10, 20, 30, 40});
  write_run(runs + "inter.p2v1.s0_20", 1, 0, {10, 20});
  write_run(runs + "kept2.p2v1.s0_20", 1, 2, {10, 20});
  write_run(runs + "short.p2v1.s0_40", 1, 0, {10, 30});
  write_run(runs + "plain.p2.s0_20", 0, 0, {10, 20});
  write_run(runs + "old.p2v1.s0_20", 1, -1, {10, 20});
  handscs::write_file_atomic(dir + "/sweep/results.csv",
                             "point,budget,status\nfull.p2v1.s0,40,ok\ninter.p2v1.s0,20,ok\nkept2.p2v1.s0,20,ok\n"
                             "short.p2v1.s0,40,ok\nplain.p2.s0,20,ok\nold.p2v1.s0,20,ok\ngone.p2v1.s0,20,ok\n"
                             "failed.p2v1.s0,20,failed\n");
  // full: 22.5 at steps 20 and 30 (the earlier wins), the last (40) lower. inter: step 10 not finite.
  const std::string full = runs + "full.p2v1.s0_40/checkpoints/step_000000", inter = runs + "inter.p2v1.s0_20/checkpoints/step_000000";
  handscs::write_file_atomic(dir + "/psnr.txt", full + "10.ckpt 20\n" + full + "20.ckpt 22.5\n" + full + "30.ckpt 22.5\n" +
                                                    full + "40.ckpt 21\n" + inter + "10.ckpt \"nan\"\n" + inter + "20.ckpt 25\n");
  const std::string call = "/usr/bin/python3 '" + kSource + "/tools/study/early_stopping.py' --bin " + dir +
                           "/bin --lpips-weights " + handscs_test::kLpipsAlexWeights + " --out " + dir + "/out " +
                           dir + "/sweep";
  const std::string log = dir + "/log.txt";
  REQUIRE(run(call, log) == 0);
  const std::string text = handscs::read_file(log);
  INFO(text);
  CHECK(text.find("kept2.p2v1.s0_20: kept only its newest 2 checkpoints") != std::string::npos);
  CHECK(text.find("short.p2v1.s0_40: its last checkpoint is step 30, not its budget 40") != std::string::npos);
  CHECK(text.find("plain.p2.s0_20: trained without data.validation_poses or data.validation_cameras") !=
        std::string::npos);
  CHECK(text.find("gone.p2v1.s0_20: not kept (handscs-bench without --keep-runs?)") != std::string::npos);
  CHECK(text.find("old.p2v1.s0_20: its config has no train.keep_checkpoints") != std::string::npos);

  const auto results = handscs::read_csv(dir + "/out/results.csv");
  REQUIRE(results.rows.size() == 4);
  const std::vector<std::vector<std::string>> expected = {{"full_es.p2v1.s0", "40", "ok", "20", "22.5000", "12", "30.2000"},
                                                          {"full_end.p2v1.s0", "40", "ok", "40", "21.0000", "12", "30.4000"},
                                                          {"inter_es.p2v1.s0", "20", "ok", "20", "25.0000", "12", "30.2000"},
                                                          {"inter_end.p2v1.s0", "20", "ok", "20", "25.0000", "12", "30.2000"}};
  for (size_t r = 0; r < expected.size(); ++r)
    CHECK(std::vector<std::string>(results.rows[r].begin(), results.rows[r].begin() + 7) == expected[r]);

  // 6 validation scores (no LPIPS, no regions), 3 test scores: inter's one checkpoint once, copied.
  auto calls = lines_of(dir + "/calls.txt");
  int validation_calls = 0, test_calls = 0;
  for (const auto& c : calls) {
    if (c.find("data.validation_poses=0") != std::string::npos) {
      ++test_calls;
      CHECK(c.find("--lpips-weights " + handscs_test::kLpipsAlexWeights) != std::string::npos);
      CHECK(c.find("--no-regions") == std::string::npos);
    } else {
      ++validation_calls;
      CHECK(c.find("--no-regions") != std::string::npos);
      CHECK(c.find("eval.lpips.weights=") != std::string::npos);
    }
  }
  CHECK(validation_calls == 6);
  CHECK(test_calls == 3);
  CHECK(std::filesystem::exists(dir + "/out/runs/inter_end.p2v1.s0_20/eval/summary.json"));
  CHECK(std::filesystem::exists(dir + "/out/runs/inter_end.p2v1.s0_20/eval.key.json"));

  // A second call scores nothing again; a checkpoint file rewritten is scored again (validation and
  // test: it is still the choice).
  REQUIRE(run(call, log) == 0);
  CHECK(lines_of(dir + "/calls.txt").size() == calls.size());
  handscs::write_file_atomic(full + "20.ckpt", "retrained");
  REQUIRE(run(call, log) == 0);
  calls = lines_of(dir + "/calls.txt");
  REQUIRE(calls.size() == 11);
  CHECK(calls[9].find(full + "20.ckpt") != std::string::npos);
  CHECK(calls[10].find(full + "20.ckpt") != std::string::npos);
  CHECK(calls[10].find("data.validation_poses=0") != std::string::npos);
  std::filesystem::remove_all(dir);
}

TEST_CASE("early_stopping.py: a novel-view run held out validation cameras: its test scores restore them") {
  const std::string dir = handscs_test::scratch_path("handscs_test_early_stopping_view", std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  write_fake_eval(dir);
  const std::string run_dir = dir + "/sweep/runs/view.v.s0_20";
  write_run(run_dir, 0, 0, {10, 20});
  handscs::write_file_atomic(run_dir + "/config.json",
                             R"({"data": {"validation_poses": 0, "validation_cameras": ["400004"]},
                                 "train": {"keep_checkpoints": 0}})");
  handscs::write_file_atomic(dir + "/sweep/results.csv", "point,budget,status\nview.v.s0,20,ok\n");
  const std::string ckpt = run_dir + "/checkpoints/step_000000";
  handscs::write_file_atomic(dir + "/psnr.txt", ckpt + "10.ckpt 21\n" + ckpt + "20.ckpt 20\n");
  const std::string log = dir + "/log.txt";
  REQUIRE(run("/usr/bin/python3 '" + kSource + "/tools/study/early_stopping.py' --bin " + dir + "/bin --out " + dir +
                  "/out " + dir + "/sweep",
              log) == 0);
  const auto results = handscs::read_csv(dir + "/out/results.csv");
  REQUIRE(results.rows.size() == 2);
  CHECK(std::vector<std::string>(results.rows[0].begin(), results.rows[0].begin() + 7) ==
        std::vector<std::string>{"view_es.v.s0", "20", "ok", "10", "21.0000", "12", "30.1000"});
  CHECK(std::vector<std::string>(results.rows[1].begin(), results.rows[1].begin() + 7) ==
        std::vector<std::string>{"view_end.v.s0", "20", "ok", "20", "20.0000", "12", "30.2000"});
  // Two validation calls, then two test calls that empty the validation cameras and leave
  // data.validation_poses alone (the run did not set it).
  const auto calls = lines_of(dir + "/calls.txt");
  REQUIRE(calls.size() == 4);
  for (size_t k = 0; k < calls.size(); ++k) {
    INFO(calls[k]);
    CHECK((calls[k].find("data.validation_cameras=[]") != std::string::npos) == (k >= 2));
    CHECK(calls[k].find("data.validation_poses") == std::string::npos);
  }
  std::filesystem::remove_all(dir);
}

TEST_CASE("early_stopping.py: the best validation checkpoint and the last, scored on the test poses") {
  const std::string dir = handscs_test::scratch_path("handscs_test_early_stopping", std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir + "/sweep/runs");
  const std::string log = dir + "/log.txt", capture = dir + "/capture";
  REQUIRE(run(kBin + "/handscs-synth --preset tiny --threads 1 --log-level warn --out " + capture, log) == 0);
  // 12 poses: the last 3 held out (tests), the 2 before them validation, 7 to train on.
  const std::string train = kBin + "/handscs-train --config " + kSource + "/configs/tiny.json --threads 1 " +
                            "--log-level warn --set data.root=" + capture + " train.iterations=30 " +
                            "train.checkpoint_every=10 train.keep_checkpoints=0 train.validate_every=0 " +
                            "eval.lpips.weights=" + handscs_test::kLpipsAlexWeights + " ";
  const std::string run_dir = dir + "/sweep/runs/full.p7v2.s0_30";
  REQUIRE(run(train + "data.validation_poses=2 --out " + run_dir, log) == 0);
  REQUIRE(run(train + "train.iterations=10 --out " + dir + "/sweep/runs/plain.p9.s0_10", log) == 0);
  const std::string ckpt = run_dir + "/checkpoints/step_000000";
  handscs::write_file_atomic(dir + "/sweep/results.csv",
                             "point,budget,status\nfull.p7v2.s0,30,ok\nplain.p9.s0,10,ok\n");

  const std::string lpips = handscs_test::kLpipsAlexWeights;
  const std::string script = "/usr/bin/python3 '" + kSource + "/tools/study/early_stopping.py' --bin " + kBin;
  const std::string out = dir + "/out";
  const std::string call = script + " --out " + out + " " + dir + "/sweep";  // LPIPS: the run's weights
  REQUIRE(run(call, log) == 0);
  CHECK(handscs::read_file(log).find("plain.p9.s0_10: trained without data.validation_poses or data.validation_cameras; left out") !=
        std::string::npos);

  // Every checkpoint's validation PSNR: the mean over the validation images, frames of the two
  // poses before the held-out ones.
  const auto validation = handscs::read_csv(out + "/validation.csv");
  REQUIRE(validation.rows.size() == 3);
  std::map<int, double> psnr;
  std::set<std::string> validation_images;
  for (size_t r = 0; r < validation.rows.size(); ++r) {
    const int step = std::stoi(validation.at(r, "step"));
    const std::string folder = run_dir + "/early_stopping/validation_" + std::to_string(step);
    const auto summary = summary_of(folder)["summary"];
    psnr[step] = summary["psnr"].get<double>();
    CHECK(std::abs(std::stod(validation.at(r, "psnr")) - psnr[step]) < 1e-4);
    CHECK(summary["lpips"].is_null());  // PSNR chooses; the run's LPIPS weights are not used
    double mean = 0;
    const auto images = images_of(folder, &mean);
    CHECK(images.size() == 8);  // 2 poses x 4 cameras
    CHECK(std::abs(mean - psnr[step]) < 1e-7);  // per_image.csv prints 10 significant digits
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
  REQUIRE(run("/usr/bin/python3 '" + kSource + "/tools/study/paired_gains.py' " + out +
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
  CHECK(handscs::read_file(log).find("no kept run trained with a validation split and every checkpoint") !=
        std::string::npos);
  std::filesystem::remove_all(dir);
}

TEST_CASE("early_stopping.py: the choice is the highest finite PSNR, the earlier of a tie") {
  const auto choice = [](const std::string& scores) {
    const std::string dir = handscs_test::scratch_path("handscs_test_early_stopping_choice", std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    const std::string command = "cd '" + kSource + "/tools/study' && /usr/bin/python3 -c 'import early_stopping; "
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
