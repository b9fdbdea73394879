// The three commands end to end on the tiny capture, as a user runs them: handscs-train (then
// --resume), handscs-eval in model mode, handscs-render with novel poses and a video; plus kill -9
// during checkpoint writes and a bad POSES file.
#include "test_support.h"
#include "catch_torch.h"

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <fstream>
#include <map>
#include <set>
#include <thread>

#include <nlohmann/json.hpp>

#include <opencv2/imgcodecs.hpp>
#include "core/atomic_file.h"
#include "core/available_memory.h"
#include "core/cli.h"
#include "metrics/comparison_panel.h"
#include "tiny_capture.h"
#include "run/checkpoint.h"
#include "train/trainer.h"

using handscs_test::fresh_dir;
using handscs_test::tiny_capture_dir;

namespace {
using handscs_test::kBin;
using handscs_test::kSource;
using handscs_test::snapshot;

// One log per test process: ctest -j runs the cases of this file side by side.
const std::string& log_path() {
  static const std::string path =
      (std::filesystem::temp_directory_path() / ("handscs_cli_test_" + std::to_string(getpid()) + ".log")).string();
  return path;
}

int run(const std::string& command) {
  const int status = std::system((command + " > " + log_path() + " 2>&1").c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}
std::string log_text() { return handscs::read_file(log_path()); }

// Starts handscs-train (after `prefix`, e.g. "nohup "; `extra` options after its own) on the tiny
// capture for 100000 steps into `run_dir`, its log in run_dir.log, and returns its pid once
// metrics.csv exists: it appears with the first logged step, after the stop handlers are installed.
pid_t start_long_training(const std::string& run_dir, const std::string& prefix = "",
                          const std::string& extra = "") {
  const pid_t pid = handscs_test::spawn(
      prefix + kBin + "/handscs-train --config " + kSource + "/configs/tiny.json --out " + run_dir +
      " --threads 1 --set data.root=" + tiny_capture_dir() +
      " train.iterations=100000 train.checkpoint_every=100000" + extra + " > " + run_dir + ".log 2>&1");
  REQUIRE(pid > 0);
  handscs_test::wait_until([&] { return std::filesystem::exists(run_dir + "/metrics.csv"); });
  return pid;
}

// Starts `train` (a handscs-train command ending in --set ...) with `settings` and --overwrite into
// run_dir, kills it (-9) once it has set the old run aside and logged a step; returns the folder
// the old run waits in.
std::string kill_overwrite_after_first_log(const std::string& train, const std::string& run_dir,
                                           const std::string& settings) {
  const pid_t pid = handscs_test::spawn(train + " train.iterations=100000 train.checkpoint_every=100000" +
                                        settings + " --overwrite > /dev/null 2>&1");
  REQUIRE(pid > 0);
  const std::string aside = run_dir + "/.overwritten." + std::to_string(pid);
  handscs_test::wait_until([&] {
    return std::filesystem::exists(aside) && std::filesystem::exists(run_dir + "/metrics.csv");
  });
  kill(pid, SIGKILL);
  handscs_test::exit_code_of(pid);
  return aside;
}

// Waits for a training run stopped by a signal: exit 130, a checkpoint of the step reached and the
// line saying so. Returns that step.
int64_t check_stopped_with_checkpoint(pid_t pid, const std::string& run_dir) {
  CHECK(handscs_test::exit_code_of(pid) == 130);
  const auto latest = handscs::latest_checkpoint(run_dir);
  REQUIRE_FALSE(latest.empty());
  const auto step = handscs::load_checkpoint(latest).meta["iteration"].get<int64_t>();
  CHECK(handscs::read_file(run_dir + ".log").find("interrupted at step " + std::to_string(step) +
                                                  ": checkpoint " + latest + " saved") != std::string::npos);
  return step;
}
}  // namespace

TEST_CASE("cli: train, resume, evaluate and render the tiny capture") {
  const auto run_dir = fresh_dir("cli_run");
  const std::string common = " --threads 2 --set data.root=" + tiny_capture_dir();
  REQUIRE(run(kBin + "/handscs-train --config " + kSource + "/configs/tiny.json --out " + run_dir +
              common + " train.iterations=40") == 0);
  CHECK(handscs::latest_checkpoint(run_dir).find("step_00000040.ckpt") != std::string::npos);
  REQUIRE(run(kBin + "/handscs-train --resume --out " + run_dir +
              " --threads 2 --set train.iterations=50") == 0);
  INFO(log_text());
  CHECK(log_text().find("resumed from") != std::string::npos);
  CHECK(handscs::latest_checkpoint(run_dir).find("step_00000050.ckpt") != std::string::npos);
  // Resumed at its last step: said so, with no rate of zero views.
  REQUIRE(run(kBin + "/handscs-train --resume --out " + run_dir + " --threads 2") == 0);
  CHECK(log_text().find(run_dir + ": already at step 50 of train.iterations = 50: nothing to train") !=
        std::string::npos);
  CHECK(log_text().find("views/s") == std::string::npos);
  {
    // The validation picture is labelled: render | ground truth | error under a header
    // (tiny.json validates every 50 steps; the tiny capture's images are 167x256 or 256x167).
    const cv::Mat panel = cv::imread(run_dir + "/validation/step_00000050.png");
    REQUIRE_FALSE(panel.empty());
    const int w = panel.cols / 3;
    CHECK(panel.cols == 3 * w);
    REQUIRE((w == 167 || w == 256));
    CHECK(panel.rows == (w == 167 ? 256 : 167) + handscs::comparison_panel_header_height(w));
  }
  {
    // Every metrics.csv row has a cell per column; the decoder gates are logged on each row.
    std::ifstream csv(run_dir + "/metrics.csv");
    std::string header, row;
    std::getline(csv, header);
    const auto cells = [](const std::string& line) { return std::count(line.begin(), line.end(), ',') + 1; };
    int rows = 0;
    while (std::getline(csv, row)) {
      ++rows;
      CHECK(cells(row) == cells(header));
      CHECK(row.find(",,,,,,,,,") == std::string::npos);  // the nine diagnostics are never empty
    }
    CHECK(rows == 5);  // log_every 10 over 50 steps
    CHECK(header.find(",gate_geometry,gate_appearance,gate_fusion,offset_dx,") != std::string::npos);
  }

  const auto eval_dir = run_dir + "/eval";
  REQUIRE(run(kBin + "/handscs-eval --config " + kSource + "/configs/tiny.json --checkpoint " +
              run_dir + " --out " + eval_dir + common + " --side-by-side") == 0);
  const auto summary = nlohmann::json::parse(handscs::read_file(eval_dir + "/summary.json"));
  CHECK(summary["summary"]["scored"].get<int>() == 12);  // 3 held-out poses x 4 cameras
  CHECK(summary["summary"]["psnr"].get<double>() > 10.0);
  CHECK(summary["rendering"]["fps"].get<double>() > 0);
  CHECK(std::filesystem::exists(eval_dir + "/per_image.csv"));
  CHECK(std::filesystem::exists(eval_dir + "/table.md"));
  int panels = 0;  // one labelled render | ground truth | error panel per scored image
  for (const auto& entry : std::filesystem::directory_iterator(eval_dir + "/side_by_side"))
    panels += entry.path().extension() == ".png";
  CHECK(panels == 12);

  const auto poses = run_dir + "/poses.json";
  std::ofstream(poses) << R"({"poses": [{"pose": [0,0,0, 0.3,0,0, 0.3,0,0, 0.3,0,0, 0,0,0,0,0,0,0,0,0,
      0,0,0,0,0,0,0,0,0, 0,0,0,0,0,0,0,0,0, 0,0,0,0,0,0,0,0,0]},
      {"pose": [0.2,0.1,0, 0,0,-0.5, 0,0,-0.5, 0,0,-0.5, 0,0,0,0,0,0,0,0,0,
      0,0,0,0,0,0,0,0,0, 0,0,0,0,0,0,0,0,0, 0.1,0.2,0,0,0,0,0,0,0], "trans": [0, 0, 0.01]}]})";
  const auto frames = run_dir + "/frames";
  REQUIRE(run(kBin + "/handscs-render --checkpoint " + run_dir + " --poses " + poses +
              " --orbit 4 --out " + frames + " --video " + frames + "/orbit.mp4 --export-ply --threads 2") == 0);
  for (int k = 0; k < 4; ++k) {
    const std::string name = frames + "/frame_000" + std::to_string(k);
    CHECK(std::filesystem::exists(name + ".png"));
    CHECK(std::filesystem::exists(name + "_alpha.png"));
    CHECK(std::filesystem::exists(name + ".ply"));
  }
  CHECK(std::filesystem::file_size(frames + "/orbit.mp4") > 1000);
  CHECK(log_text().find("FPS") != std::string::npos);
}

TEST_CASE("cli: a bad POSES file gives a clear error") {
  const auto dir = fresh_dir("cli_poses");
  std::filesystem::create_directories(dir);
  auto config = handscs_test::tiny_run_config();
  config.train.iterations = 1;
  {
    handscs::Trainer t(config, dir + "/run");
    t.step();
    t.save_checkpoint();
  }
  std::ofstream(dir + "/short.json") << R"({"poses": [{"pose": [0, 0, 0]}]})";
  CHECK(run(kBin + "/handscs-render --checkpoint " + dir + "/run --poses " + dir +
            "/short.json --orbit 2 --out " + dir + "/out") == 1);
  CHECK(log_text().find(dir + "/short.json: poses[0].pose: expected 48 numbers, got 3 values") !=
        std::string::npos);
  std::ofstream(dir + "/broken.json") << "{\"poses\": [";
  CHECK(run(kBin + "/handscs-render --checkpoint " + dir + "/run --poses " + dir +
            "/broken.json --orbit 2 --out " + dir + "/out") == 1);
  CHECK(log_text().find(dir + "/broken.json: malformed JSON") != std::string::npos);
  // A frame rate the video writer cannot use is refused by name before anything renders.
  std::ofstream(dir + "/one.json") << R"({"poses": [{"pose": [0,0,0, 0,0,0, 0,0,0, 0,0,0,
      0,0,0,0,0,0,0,0,0, 0,0,0,0,0,0,0,0,0, 0,0,0,0,0,0,0,0,0, 0,0,0,0,0,0,0,0,0]}]})";
  for (const std::string fps : {"0", "nan", "-5", "1e9"}) {
    INFO(fps);
    CHECK(run(kBin + "/handscs-render --checkpoint " + dir + "/run --poses " + dir +
              "/one.json --orbit 2 --video " + dir + "/v.mp4 --fps " + fps + " --out " + dir + "/out") != 0);
    CHECK(log_text().find("--fps " + fps + ": a frame rate in [1, 240]") != std::string::npos);
  }
}

TEST_CASE("cli: kill -9 during checkpoint writes leaves a loadable checkpoint") {
  const auto run_dir = fresh_dir("cli_kill");
  // A checkpoint every step, so the kill lands inside or between writes; a few kills at
  // different times.
  // --resume: the first start finds no checkpoint and starts afresh, the later ones continue.
  const std::string command = kBin + "/handscs-train --resume --config " + kSource +
                              "/configs/tiny.json --out " + run_dir +
                              " --threads 1 --log-level error --set data.root=" + tiny_capture_dir() +
                              " train.iterations=100000 train.checkpoint_every=1";
  for (int delay_ms : {120, 370, 630}) {
    const auto before = handscs::latest_checkpoint(run_dir);
    const pid_t pid = handscs_test::spawn(command + " > /dev/null 2>&1");
    REQUIRE(pid > 0);
    // Wait until this start has written a checkpoint of its own (it is writing one every step
    // then), then kill at an arbitrary moment.
    handscs_test::wait_until([&] { return handscs::latest_checkpoint(run_dir) != before; });
    std::this_thread::sleep_for(std::chrono::milliseconds(delay_ms));
    kill(pid, SIGKILL);
    handscs_test::exit_code_of(pid);
    const auto latest = handscs::latest_checkpoint(run_dir);
    REQUIRE_FALSE(latest.empty());
    CHECK(latest != before);  // this start wrote checkpoints before its kill
    INFO(latest);
    CHECK_NOTHROW(handscs::load_checkpoint(latest));
    // Every file that looks like a checkpoint is complete (temporaries have another name).
    for (const auto& entry : std::filesystem::directory_iterator(run_dir + "/checkpoints"))
      if (entry.path().extension() == ".ckpt") CHECK_NOTHROW(handscs::load_checkpoint(entry.path()));
  }
  // A last resume (to a step already passed: it stops at once) removes the temporaries of killed
  // writes and leaves one metrics row per logged step.
  REQUIRE(run(kBin + "/handscs-train --resume --out " + run_dir +
              " --threads 1 --set train.iterations=1") == 0);
  for (const auto& entry : std::filesystem::directory_iterator(run_dir + "/checkpoints"))
    CHECK(entry.path().filename().string().find(".tmp.") == std::string::npos);
  std::ifstream csv(run_dir + "/metrics.csv");
  std::string row;
  std::getline(csv, row);
  std::set<std::string> steps;
  while (std::getline(csv, row)) {
    INFO(row);
    CHECK(steps.insert(row.substr(0, row.find(','))).second);
  }
}

TEST_CASE("cli: a run that outgrows the memory it may use ends naming the step and the keys") {
  // Densification doubling the Gaussians every step under a 4 GB address-space limit (prlimit),
  // its cap at half the machine's available memory by the start-up estimate (which the limit does
  // not see), so the run starts and fails late.
  const double per_gaussian = 2.9e3 + 58 * 256;  // train/train_memory.cpp at model.decoder_hidden 256
  const auto cap = static_cast<int64_t>(0.5 * handscs::available_memory_bytes() / per_gaussian);
  if (cap < 400000) {
    WARN("less than 14 GB available: a run that outgrows 4 GB would be refused at start; not tried");
    return;
  }
  const auto run_dir = fresh_dir("cli_oom");
  CHECK(run("prlimit --as=4000000000 " + kBin + "/handscs-train --config " + kSource +
            "/configs/tiny.json --out " + run_dir + " --threads 1 --set data.root=" + tiny_capture_dir() +
            " train.iterations=200 train.validate_every=0 train.checkpoint_every=100000 train.log_every=1"
            " train.densify.start=1 train.densify.interval=1 train.densify.grad_threshold=0"
            " train.densify.stop=1000 train.densify.max_gaussians=" + std::to_string(cap)) == 1);
  INFO(log_text());
  CHECK(log_text().find("out of memory at step ") != std::string::npos);
  CHECK(log_text().find("Gaussians") != std::string::npos);
  CHECK(log_text().find("train.densify.max_gaussians") != std::string::npos);
  CHECK(log_text().find("enforce fail") == std::string::npos);  // not LibTorch's words alone
  // It logged steps (config.json and metrics.csv written) and ended before its first checkpoint:
  // what it wrote is gone, so a rerun needs no --overwrite.
  CHECK(log_text().find("(config.json, metrics.csv)") != std::string::npos);
  CHECK_FALSE(std::filesystem::exists(run_dir + "/config.json"));
  CHECK_FALSE(std::filesystem::exists(run_dir + "/metrics.csv"));
  CHECK(log_text().find("the run ended before its first checkpoint: removed what it wrote") != std::string::npos);
}

TEST_CASE("cli: SIGTERM stops training with a checkpoint of the step reached and exit 130") {
  const auto run_dir = fresh_dir("cli_sigterm");
  const pid_t pid = start_long_training(run_dir);
  kill(pid, SIGTERM);
  const int64_t step = check_stopped_with_checkpoint(pid, run_dir);
  CHECK(step > 0);
  CHECK(step < 100000);
}

TEST_CASE("cli: SIGHUP stops training as SIGTERM does, unless nohup ignores it") {
  // The terminal closed: a checkpoint of the step reached, exit 130, the same line as for SIGTERM.
  const auto run_dir = fresh_dir("cli_sighup");
  pid_t pid = start_long_training(run_dir);
  kill(pid, SIGHUP);
  check_stopped_with_checkpoint(pid, run_dir);

  // Under nohup the run outlives its terminal: it keeps logging steps after the SIGHUP.
  const auto metrics_rows = [&] {
    const std::string text = handscs::read_file(run_dir + "/metrics.csv");
    return std::count(text.begin(), text.end(), '\n');
  };
  const auto before = metrics_rows();
  pid = start_long_training(run_dir, "nohup ", " --resume");
  handscs_test::wait_until([&] { return metrics_rows() > before; });
  kill(pid, SIGHUP);
  const auto at_hangup = metrics_rows();
  CHECK(handscs_test::wait_until([&] { return metrics_rows() > at_hangup + 1; }));
  int status = 0;
  CHECK(waitpid(pid, &status, WNOHANG) == 0);  // still training
  kill(pid, SIGTERM);
  check_stopped_with_checkpoint(pid, run_dir);
}

TEST_CASE("cli: the closing evaluate line is a command that runs as printed") {
  // --set overrides the config file lacks (data.root), and a run folder whose name needs quoting.
  const auto run_dir = fresh_dir("cli_evaluate_hint") + " it's";
  REQUIRE(run(kBin + "/handscs-train --config " + kSource + "/configs/tiny.json --out " +
              handscs::shell_quote(run_dir) + " --threads 2 --set data.root=" + tiny_capture_dir() +
              " train.iterations=2 model.embedding_dim=8") == 0);
  const std::string log = log_text();
  const auto start = log.find("evaluate:   handscs-eval ");
  REQUIRE(start != std::string::npos);
  const std::string line = log.substr(start, log.find('\n', start) - start);
  CHECK(line == "evaluate:   handscs-eval --checkpoint " + handscs::shell_quote(run_dir) + " --out " +
                    handscs::shell_quote(run_dir + "/eval"));
  const std::string command = line.substr(line.find("handscs-eval"));
  INFO(command);
  CHECK(run(kBin + "/" + command + " --threads 2 --max-images 2") == 0);
  INFO(log_text());
  CHECK(std::filesystem::exists(run_dir + "/eval/summary.json"));
}

TEST_CASE("cli: handscs-eval refuses a split other than the run trained with") {
  const auto run_dir = fresh_dir("cli_eval_split");
  REQUIRE(run(kBin + "/handscs-train --config " + kSource + "/configs/tiny.json --out " + run_dir +
              " --threads 2 --set data.root=" + tiny_capture_dir() +
              " train.iterations=2 data.validation_poses=2") == 0);
  const std::string checkpoint = run_dir + "/checkpoints/step_00000002.ckpt";
  const std::string eval = kBin + "/handscs-eval --checkpoint " + run_dir + " --threads 2 --max-images 1 --out " +
                           run_dir + "_eval";
  const std::string advice = "its scores would mix two experiments (training images may score as test images): "
                             "evaluate with the run's split (data.root may name the capture's new place)";
  CHECK(run(eval + " --set data.held_out_poses=9") == 1);
  CHECK(log_text().find("--set changes which images " + checkpoint + " trained and tests on (checkpoint -> "
                        "given):\n  data.held_out_poses: 3 -> 9\n" + advice) != std::string::npos);
  CHECK(run(eval + " --set data.validation_poses=1") == 1);
  CHECK(log_text().find("  data.validation_poses: 2 -> 1\n") != std::string::npos);
  // A config file is named as the source; the key it changes, not the others it shares.
  const std::string config = run_dir + "_other_split.json";
  std::ofstream(config) << R"({"extends": ")" << kSource << R"(/configs/tiny.json", "data": {"root": ")"
                        << tiny_capture_dir() << R"(", "held_out_poses": 4, "validation_poses": 2}})";
  CHECK(run(eval + " --config " + config) == 1);
  CHECK(log_text().find(config + " changes which images " + checkpoint + " trained and tests on (checkpoint -> "
                        "given):\n  data.held_out_poses: 3 -> 4\n" + advice) != std::string::npos);
  CHECK_FALSE(std::filesystem::exists(run_dir + "_eval/summary.json"));
  // Dropping the validation split scores the capture's own test poses, which the run never saw.
  CHECK(run(eval + " --set data.validation_poses=0") == 0);
  CHECK(std::filesystem::exists(run_dir + "_eval/summary.json"));
}

TEST_CASE("cli: handscs-eval and a resume refuse another capture at data.root, not the same one moved") {
  // Another seed of the same preset: the same layout, cameras ids, image names and split keys.
  const auto run_dir = fresh_dir("cli_other_capture");
  const std::string other = run_dir + "_capture_seed2";
  auto preset = handscs::synth_preset("tiny");
  preset.seed += 1;
  handscs::generate_synth_capture(preset, other);
  const std::string train = kBin + "/handscs-train --config " + kSource + "/configs/tiny.json --out " + run_dir +
                            " --threads 2 --set train.iterations=2";
  REQUIRE(run(train + " data.root=" + tiny_capture_dir()) == 0);
  const std::string checkpoint = run_dir + "/checkpoints/step_00000002.ckpt";
  const std::string eval = kBin + "/handscs-eval --checkpoint " + run_dir + " --threads 2 --max-images 1 --out " +
                           run_dir + "_eval";

  CHECK(run(eval + " --set data.root=" + other) == 1);
  // Another seed moves the cameras and the hands alike.
  CHECK(log_text().find("the frames " + other + " gives differ from those " + checkpoint + " trained on (the "
                        "cameras' calibration; the image names or the annotated hands): another capture, or a "
                        "data setting that selects other frames.\nIts scores would not be the run's: evaluate "
                        "on the run's capture, or pass --other-capture to score these frames anyway") !=
        std::string::npos);
  CHECK_FALSE(std::filesystem::exists(run_dir + "_eval/summary.json"));
  CHECK(run(eval + " --set data.root=" + other + " --other-capture") == 0);
  CHECK(log_text().find("scoring it as asked (--other-capture)") != std::string::npos);
  std::filesystem::remove_all(run_dir + "_eval");

  // The run's own capture, moved: the same frames, cameras and hands.
  const std::string moved = run_dir + "_capture_moved";
  std::filesystem::copy(tiny_capture_dir(), moved, std::filesystem::copy_options::recursive);
  CHECK(run(eval + " --set data.root=" + moved) == 0);
  CHECK(std::filesystem::exists(run_dir + "_eval/summary.json"));

  // A run on that copy, its capture then replaced in the same folder: the resume is refused before
  // a step (data.root itself may not change on resume), and the run folder is left as it was.
  const std::string moved_run = run_dir + "_moved_run";
  const std::string train_moved = kBin + "/handscs-train --config " + kSource + "/configs/tiny.json --out " +
                                  moved_run + " --threads 2 --set data.root=" + moved;
  REQUIRE(run(train_moved + " train.iterations=2") == 0);
  std::filesystem::remove_all(moved);
  std::filesystem::copy(other, moved, std::filesystem::copy_options::recursive);
  const auto before = snapshot(moved_run);
  CHECK(run(train_moved + " train.iterations=4 --resume") != 0);
  CHECK(log_text().find("the frames " + moved + " gives differ from those the run trained on (the cameras' "
                        "calibration; the image names or the annotated hands): another capture, or a data "
                        "setting that selects other frames\nresume on the run's capture, or pass "
                        "--resume-changing-data") !=
        std::string::npos);
  CHECK(snapshot(moved_run) == before);
}

TEST_CASE("cli: handscs-eval takes a run's capture without its validation cameras as the run's") {
  // Validation cameras leave the test cameras unopened, so the run's frames are its training
  // cameras'; dropped at evaluation, the test cameras open beside them (tools/study/early_stopping.py).
  const auto run_dir = fresh_dir("cli_eval_validation_cameras");
  REQUIRE(run(kBin + "/handscs-train --config " + kSource + "/configs/tiny.json --out " + run_dir +
              " --threads 2 --set data.root=" + tiny_capture_dir() + " train.iterations=2 "
              "data.split_rule=novel_view 'data.test_cameras=[\"400008\"]' "
              "'data.validation_cameras=[\"400004\"]'") == 0);
  const std::string eval = kBin + "/handscs-eval --checkpoint " + run_dir + " --threads 2 --max-images 1 --out " +
                           run_dir + "_eval";
  INFO(log_text());
  CHECK(run(eval + " --set 'data.validation_cameras=[]'") == 0);
  CHECK(std::filesystem::exists(run_dir + "_eval/summary.json"));
}

TEST_CASE("cli: SIGTERM stops a render, keeping the frames written and no torn video") {
  const auto run_dir = fresh_dir("cli_render_stop");
  REQUIRE(run(kBin + "/handscs-train --config " + kSource + "/configs/tiny.json --out " + run_dir +
              " --threads 1 --set data.root=" + tiny_capture_dir() + " train.iterations=2") == 0);
  const std::string poses = run_dir + "_poses.json";
  std::ofstream(poses) << R"({"capture": {"root": ")" << tiny_capture_dir()
                       << R"(", "held_out_poses": 3}, "frames": "test"})";
  const std::string out = run_dir + "_render";
  const pid_t pid = handscs_test::spawn(kBin + "/handscs-render --checkpoint " + run_dir + " --poses " +
                                        poses + " --orbit 100000 --threads 1 --out " + out +
                                        " --video " + out + "/v.mp4 > " + out + ".log 2>&1");
  REQUIRE(pid > 0);
  // The first frame's PNG appears after the handlers are installed.
  handscs_test::wait_until([&] { return std::filesystem::exists(out + "/frame_0000.png"); });
  kill(pid, SIGTERM);
  CHECK(handscs_test::exit_code_of(pid) == 1);
  const std::string log = handscs::read_file(out + ".log");
  CHECK(log.find("render interrupted (SIGINT, SIGTERM or SIGHUP) after ") != std::string::npos);
  CHECK(log.find(" of 100000 frames, kept in " + out + "; the video was not written") !=
        std::string::npos);
  CHECK(std::filesystem::exists(out + "/frame_0000.png"));
  CHECK_FALSE(std::filesystem::exists(out + "/v.mp4"));
  CHECK_FALSE(std::filesystem::exists(out + "/v.mp4.tmp.mp4"));
}

TEST_CASE("cli: a run folder is never overwritten or mixed without --overwrite") {
  const auto run_dir = fresh_dir("cli_safe");
  const std::string train = kBin + "/handscs-train --config " + kSource + "/configs/tiny.json --out " +
                            run_dir + " --threads 2 --set data.root=" + tiny_capture_dir();
  REQUIRE(run(train + " train.iterations=4") == 0);
  const auto before = snapshot(run_dir);
  REQUIRE(before.count(run_dir + "/checkpoints/step_00000004.ckpt") == 1);

  // A fresh run into it: refused, nothing changed.
  CHECK(run(train + " train.iterations=2") == 1);
  CHECK(log_text().find(run_dir + " holds a run (1 checkpoint (newest step_00000004.ckpt), "
                        "config.json, metrics.csv)") != std::string::npos);
  CHECK(snapshot(run_dir) == before);

  // A resume with another model: refused with the keys that differ, nothing changed.
  CHECK(run(kBin + "/handscs-train --resume --out " + run_dir +
            " --threads 2 --set model.embedding_dim=16 train.iterations=6") == 1);
  INFO(log_text());
  CHECK(log_text().find("model.embedding_dim: 32 -> 16") != std::string::npos);
  CHECK(log_text().find("nothing was changed") != std::string::npos);
  CHECK(snapshot(run_dir) == before);

  // A resume with a config that fails (a bad value; a capture that cannot be opened): refused
  // before config.json is touched.
  const auto bad = run_dir + "_bad.json";
  std::ofstream(bad) << R"({"train": {"iterations": -3}})";
  CHECK(run(kBin + "/handscs-train --resume --out " + run_dir + " --config " + bad) == 1);
  CHECK(log_text().find("train.iterations") != std::string::npos);
  CHECK(snapshot(run_dir) == before);
  std::ofstream(bad) << R"({"data": {"root": "/nonexistent/capture"}})";
  CHECK(run(kBin + "/handscs-train --resume --out " + run_dir + " --config " + bad) == 1);
  CHECK(log_text().find("/nonexistent/capture") != std::string::npos);
  CHECK(snapshot(run_dir) == before);

  // handscs-eval names the checkpoint it scores.
  REQUIRE(run(kBin + "/handscs-eval --checkpoint " + run_dir + " --out " + run_dir +
              "_eval --max-images 2 --threads 2") == 0);
  CHECK(log_text().find("checkpoint: " + run_dir + "/checkpoints/step_00000004.ckpt (step 4)") !=
        std::string::npos);

  // --overwrite with a new run that fails its checks (a capture that cannot be opened, images too
  // small at the asked resolution, nothing to learn): refused, the old run every byte as it was
  // (the evaluation above added masks of the test images to the run's mask cache).
  const auto evaluated = snapshot(run_dir);
  CHECK(run(train + " train.iterations=2 data.root=/nonexistent/capture --overwrite") == 1);
  CHECK(log_text().find("/nonexistent/capture") != std::string::npos);
  CHECK(snapshot(run_dir) == evaluated);
  CHECK(run(train + " train.iterations=2 train.resolution_scale=0.05 --overwrite") == 1);
  CHECK(log_text().find("train.resolution_scale") != std::string::npos);
  CHECK(snapshot(run_dir) == evaluated);
  CHECK(run(train + " train.iterations=2 train.loss.rgb=0 train.loss.mask=0 train.loss.ssim=0 "
                    "train.loss.lpips=0 train.loss.reg=0 train.loss.consistency=0 --overwrite") == 1);
  CHECK(log_text().find("train.loss: every weight (rgb, mask, ssim, lpips, reg, consistency) is 0") !=
        std::string::npos);
  CHECK(snapshot(run_dir) == evaluated);

  // --overwrite killed (-9) before the new run's first checkpoint: the old run waits set aside,
  // and the next handscs-train in the folder puts it back, every byte as it was.
  {
    REQUIRE(std::filesystem::is_directory(kill_overwrite_after_first_log(train, run_dir, "")));
    CHECK(run(train + " train.iterations=2") == 1);  // no --overwrite: refused, old run back first
    CHECK(log_text().find("an interrupted --overwrite had set the earlier run aside before the new "
                          "run's first checkpoint; it is back") != std::string::npos);
    auto restored = snapshot(run_dir);  // the shared mask cache may have grown; the run is as was
    auto expected = evaluated;
    for (auto* files : {&restored, &expected})
      for (auto it = files->begin(); it != files->end();)
        it = it->first.rfind(run_dir + "/cache/", 0) == 0 ? files->erase(it) : std::next(it);
    CHECK(restored == expected);
  }
  // The same with another model, then --resume without a config: the old run comes back before its
  // config.json is read, and resumes (the killed run's config is not taken for the run's).
  {
    kill_overwrite_after_first_log(train, run_dir, " model.decoder_hidden=32");
    CHECK(run(kBin + "/handscs-train --resume --out " + run_dir + " --threads 1") == 0);
    INFO(log_text());
    CHECK(log_text().find("it is back") != std::string::npos);
    CHECK(log_text().find("resumed from") != std::string::npos);
    CHECK(log_text().find("model differs") == std::string::npos);
  }

  // --overwrite replaces the run: the old checkpoint is gone, the new run's is there.
  CHECK(run(train + " train.iterations=2 --resume --overwrite") != 0);  // exclusive flags
  REQUIRE(run(train + " train.iterations=2 --overwrite") == 0);
  CHECK_FALSE(std::filesystem::exists(run_dir + "/checkpoints/step_00000004.ckpt"));
  CHECK(std::filesystem::exists(run_dir + "/checkpoints/step_00000002.ckpt"));
}

TEST_CASE("cli: handscs-eval refuses damaged ground truth and --set model.*") {
  const auto run_dir = fresh_dir("cli_eval_refusals");
  REQUIRE(run(kBin + "/handscs-train --config " + kSource + "/configs/tiny.json --out " + run_dir +
              " --threads 2 --set data.root=" + tiny_capture_dir() + " train.iterations=2") == 0);
  const std::string eval = kBin + "/handscs-eval --checkpoint " + run_dir + " --threads 2 --max-images 2 --out " +
                           run_dir + "_eval";
  // A negative image count names the bound, not a 309-digit one.
  CHECK(run(eval + " --max-images -1") != 0);
  CHECK(log_text().find("100000000") != std::string::npos);
  CHECK(log_text().find("1797693134862315") == std::string::npos);
  CHECK(run(eval + " --set model.embedding_dim=16") == 1);
  CHECK(log_text().find("--set model.embedding_dim=16: the model is the checkpoint's and cannot be changed "
                        "after training") != std::string::npos);
  // Without --config the overrides apply to the checkpoint's stored config: an unknown key is named.
  CHECK(run(eval + " --set data.no_such_key=1") == 1);
  CHECK(log_text().find("data.no_such_key") != std::string::npos);
  // A copy of the capture with one truncated JPEG: training would skip it, evaluation refuses.
  const auto capture = fresh_dir("cli_eval_damaged_capture");
  std::filesystem::copy(tiny_capture_dir(), capture, std::filesystem::copy_options::recursive);
  std::string damaged;
  for (const auto& entry : std::filesystem::recursive_directory_iterator(capture + "/images"))
    if (entry.path().extension() == ".jpg") damaged = entry.path().string();
  REQUIRE_FALSE(damaged.empty());
  const std::string whole = handscs::read_file(damaged);
  std::ofstream(damaged, std::ios::binary | std::ios::trunc) << whole.substr(0, whole.size() / 2);
  CHECK(run(eval + " --set data.root=" + capture) == 1);
  INFO(log_text());
  CHECK(log_text().find(damaged + ": damaged JPEG (truncated: the image data ends without an end-of-image "
                        "marker): skipped") != std::string::npos);
  CHECK(log_text().find("1 damaged JPEG(s) in the capture (first: " + damaged) != std::string::npos);
  CHECK_FALSE(std::filesystem::exists(run_dir + "_eval/summary.json"));

  // A background out of range stored by an older build (training refuses it now) is named with
  // the checkpoint it came from, not blamed on the command line.
  const std::string stored_bad = run_dir + "_background.ckpt";
  auto checkpoint = handscs::load_checkpoint(handscs::latest_checkpoint(run_dir));
  checkpoint.meta["config"]["eval"]["background"] = {2, -1, 0.5};
  handscs::save_checkpoint(stored_bad, checkpoint);
  const std::string eval_bad = kBin + "/handscs-eval --checkpoint " + stored_bad +
                               " --threads 2 --max-images 2 --out " + run_dir + "_eval";
  CHECK(run(eval_bad) == 1);
  CHECK(log_text().find(stored_bad + " (its stored config): eval.background: values must be in [0, 1] "
                        "(got 2)") != std::string::npos);
  CHECK(run(eval_bad + " --set eval.background=[0,0,0]") == 0);  // overridden: scored

  // A device where a checkpoint, LPIPS weights or a PLY belong is refused by name at once.
  const std::string device = ": is not a regular file (a named pipe, a device or a socket); give a file";
  CHECK(run(kBin + "/handscs-eval --checkpoint /dev/zero --out " + run_dir + "_eval") == 1);
  CHECK(log_text().find("/dev/zero" + device) != std::string::npos);
  CHECK(run(eval + " --lpips-weights /dev/zero") == 1);
  CHECK(log_text().find("/dev/zero" + device) != std::string::npos);
  const std::string camera = run_dir + "_camera.json";
  std::ofstream(camera) << R"({"K": [[100, 0, 32], [0, 100, 32], [0, 0, 1]],
    "R": [[1, 0, 0], [0, 1, 0], [0, 0, 1]], "t": [0, 0, 0], "width": 64, "height": 64})";
  CHECK(run(kBin + "/handscs-render --ply /dev/zero --camera " + camera + " --out " + run_dir + "_x.png") == 1);
  CHECK(log_text().find("/dev/zero" + device) != std::string::npos);
}

TEST_CASE("cli: user errors print their message without a stack trace, and name what is wrong") {
  const auto dir = fresh_dir("cli_user_errors");
  std::filesystem::create_directories(dir);
  const std::string train = kBin + "/handscs-train --config " + kSource + "/configs/tiny.json --threads 2 --set data.root=" +
                            tiny_capture_dir();
  // A scale that shrinks the images below the SSIM window: refused before step 1.
  CHECK(run(train + " train.iterations=2 train.resolution_scale=0.05 --out " + dir + "/small") == 1);
  CHECK(log_text().find("train.resolution_scale: 0.05 scales the 167x256 images") != std::string::npos);
  CHECK(log_text().find("Exception raised from") == std::string::npos);
  CHECK(log_text().find("frame #") == std::string::npos);

  // novel_view asking for more cameras than the capture has: a warning with what is used.
  REQUIRE(run(train + " train.iterations=2 data.split_rule=novel_view --out " + dir + "/views") == 0);
  CHECK(log_text().find("data.novel_view_train_views = 10 and data.novel_view_test_views = 15 ask for 25 "
                        "cameras; capture 0 has 4: using 2 training and 2 test cameras") != std::string::npos);

  // A camera that faces away from the hand: every frame is background, so the render fails.
  std::ofstream(dir + "/poses.json") << R"({"poses": [{"pose": [0,0,0, 0.3,0,0, 0.3,0,0, 0.3,0,0,
      0,0,0,0,0,0,0,0,0, 0,0,0,0,0,0,0,0,0, 0,0,0,0,0,0,0,0,0, 0,0,0,0,0,0,0,0,0]}]})";
  const std::string camera = R"({"K": [[300,0,128],[0,300,128],[0,0,1]], "R": [[1,0,0],[0,1,0],[0,0,1]], )";
  std::ofstream(dir + "/front.json") << camera << R"("t": [0,0,0.5], "width": 256, "height": 256})";
  std::ofstream(dir + "/away.json") << camera << R"("t": [0,0,-0.5], "width": 256, "height": 256})";
  const std::string render = kBin + "/handscs-render --checkpoint " + dir + "/views --poses " + dir +
                             "/poses.json --threads 2 --camera ";
  CHECK(run(render + dir + "/front.json --out " + dir + "/front") == 0);
  CHECK(run(render + dir + "/away.json --out " + dir + "/away") == 1);
  CHECK(log_text().find("frame_0000: the hand of pose pose_0000 is not in view of " + dir + "/away.json") !=
        std::string::npos);
  CHECK(log_text().find("no frame shows the hand: in all 1 frames it is behind the camera or outside "
                        "the image (" + dir + "/away.json)") != std::string::npos);
}
