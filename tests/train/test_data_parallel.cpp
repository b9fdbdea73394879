// Data-parallel training as users run it: handscs-train processes on loopback, rendezvous from the
// environment (RANK, WORLD_SIZE, MASTER_ADDR, MASTER_PORT). Two ranks with one view each against
// one process with batch_size 2 (densification inside the window; pose refinement; per-camera
// colour transforms), a 2-rank run resumed exactly, a killed rank, a rank alone, and resuming a
// 2-rank run with 1 rank and a 1-rank run with 2. In process (two ranks as two threads): a NaN on
// one rank is skipped and rolled back on both.
#include "test_support.h"
#include "catch_torch.h"

#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <chrono>
#include <functional>
#include <fstream>
#include <set>
#include <thread>
#include <utility>

#include "checkpoint_compare.h"
#include "core/atomic_file.h"
#include "core/csv_table.h"
#include "tiny_capture.h"
#include "two_hand_capture.h"
#include "run/checkpoint.h"
#include "train/data_parallel.h"
#include "train/reduce_slots.h"
#include "train/trainer.h"

using handscs_test::fresh_dir;
using handscs_test::tiny_capture_dir;

namespace {
using handscs_test::kBin;
using handscs_test::kSource;

// A port free now (the kernel's pick for port 0), so parallel test processes never collide.
int free_port() {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  address.sin_port = 0;
  REQUIRE(bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof(address)) == 0);
  socklen_t length = sizeof(address);
  getsockname(fd, reinterpret_cast<sockaddr*>(&address), &length);
  close(fd);
  return ntohs(address.sin_port);
}

int shell(const std::string& script) {
  const int status = std::system(("bash -c '" + script + "'").c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

struct Timed {
  int exit_code;
  double seconds;
};
Timed timed_shell(const std::string& script) {
  const auto started = std::chrono::steady_clock::now();
  const int rc = shell(script);
  return {rc, std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count()};
}

// 12 steps of the tiny capture, densifying at steps 4, 8 and 12 (a threshold that picks some
// Gaussians, not all: the decision depends on the summed statistics).
std::string train_command(const std::string& out) {
  return kBin + "/handscs-train --config " + kSource + "/configs/tiny.json --out " + out +
         " --threads 1 --set data.root=" + tiny_capture_dir() +
         " train.iterations=12 train.validate_every=0 train.densify.enabled=true"
         " train.densify.start=4 train.densify.interval=4 train.densify.grad_threshold=1e-5";
}

// Rank 1's command: it needs only --out (rank 0's config reaches it).
std::string rank1_command(const std::string& out) { return kBin + "/handscs-train --threads 1 --out " + out; }

std::string rank_env(int rank, int port) {
  return "RANK=" + std::to_string(rank) + " WORLD_SIZE=2 MASTER_ADDR=127.0.0.1 MASTER_PORT=" +
         std::to_string(port) + " ";
}

// Rank 0 runs `command`, rank 1 `rank1` (rank 0's config reaches it); returns the larger exit
// code.
int run_two_ranks(const std::string& command, const std::string& rank1, const std::string& log) {
  const int port = free_port();
  return shell(rank_env(0, port) + command + " > " + log + ".0 2>&1 & p0=$!; " +
               rank_env(1, port) + rank1 + " > " + log + ".1 2>&1; r1=$?; wait $p0; "
               "r0=$?; exit $(( r0 > r1 ? r0 : r1 ))");
}

// Trains DIR/single (one process, batch_size 2) and DIR/ranks (two ranks, one view each) with
// train_command + `settings`; returns their latest checkpoints (single, ranks).
std::pair<handscs::Checkpoint, handscs::Checkpoint> train_single_and_two_ranks(const std::string& dir,
                                                                              const std::string& settings) {
  std::filesystem::create_directories(dir);
  REQUIRE(shell(train_command(dir + "/single") + settings + " train.batch_size=2 > " + dir + "/single.log 2>&1") == 0);
  const int rc = run_two_ranks(train_command(dir + "/ranks") + settings,
                               rank1_command(dir + "/ranks"), dir + "/ranks.log");
  INFO(handscs::read_file(dir + "/ranks.log.0") + handscs::read_file(dir + "/ranks.log.1"));
  REQUIRE(rc == 0);
  return {handscs::load_checkpoint(handscs::latest_checkpoint(dir + "/single")),
          handscs::load_checkpoint(handscs::latest_checkpoint(dir + "/ranks"))};
}

// Runs body(group, rank) for ranks 0 and 1 as two threads of this process; returns each rank's
// error ("" when it ran through).
std::array<std::string, 2> run_rank_threads(
    const std::function<void(handscs::ProcessGroup&, int)>& body) {
  handscs::DataParallelOptions options;
  options.world_size = 2;
  options.master_port = free_port();
  options.timeout_s = 60;
  std::array<std::string, 2> errors;
  auto rank_main = [&](int rank) {
    try {
      auto mine = options;
      mine.rank = rank;
      handscs::ProcessGroup group(mine);
      body(group, rank);
    } catch (const std::exception& e) {
      errors[rank] = e.what();
    }
  };
  std::thread rank1(rank_main, 1);
  rank_main(0);
  rank1.join();
  return errors;
}

// Rank 0's checkpoint holds every tensor the single process's does (view 1's inter-pose chain,
// rank 1's, gathered, included), each equal to it within 1e-5.
void check_same_state(const handscs::Checkpoint& single, const handscs::Checkpoint& ranks) {
  for (const auto& [name, tensor] : single.tensors) {
    INFO(name);
    CHECK(ranks.tensors.count(name) == 1);
  }
  const auto difference = handscs_test::compare_checkpoints(single, ranks);
  CHECK(difference.mismatch == "");
  INFO("largest relative difference " << difference.worst << " in " << difference.worst_name);
  CHECK(difference.worst <= 1e-5);
}
}  // namespace

TEST_CASE("train: data parallel: 2 ranks x 1 view equal 1 process x batch_size 2, densifying") {
  const auto dir = fresh_dir("dp_equal");
  const auto [a, b] = train_single_and_two_ranks(dir, "");
  const auto single = dir + "/single", ranks = dir + "/ranks";
  CHECK(a.meta["iteration"] == 12);
  CHECK(b.meta["iteration"] == 12);
  CHECK(a.meta["adam_steps"] == b.meta["adam_steps"]);
  const int64_t gaussians = a.tensors.at("gaussians/means").size(0);
  CHECK(gaussians > 1696);  // densification changed the set inside the window
  check_same_state(a, b);
  // metrics.csv logs the same losses: each term the mean over both ranks' views, as the single
  // process's over its batch (the ranks sum them in float32).
  const auto log_a = handscs::read_csv(single + "/metrics.csv"), log_b = handscs::read_csv(ranks + "/metrics.csv");
  REQUIRE(log_a.rows.size() == log_b.rows.size());
  REQUIRE_FALSE(log_a.rows.empty());
  for (size_t row = 0; row < log_a.rows.size(); ++row)
    for (const char* column : {"loss", "rgb", "mask", "ssim", "reg", "consistency", "psnr"}) {
      INFO("step " << log_a.at(row, "iteration") << ", " << column);
      const std::string x = log_a.at(row, column), y = log_b.at(row, column);
      REQUIRE(x.empty() == y.empty());
      if (!x.empty()) CHECK(std::stod(y) == Approx(std::stod(x)).epsilon(1e-4));
    }
}

TEST_CASE("train: data parallel: two hands on 2 ranks equal 1 process x batch_size 2, densifying") {
  // Half the frames lack the left hand, so some steps show it on one rank only, or on none.
  handscs_test::TwoHandCaptureSpec spec;
  spec.without_left = {6, 18, 30, 42, 54, 66};
  const std::string root = handscs_test::make_two_hand_capture(fresh_dir("dp_two_hands_capture"), spec);
  const auto [single, ranks] = train_single_and_two_ranks(
      fresh_dir("dp_two_hands"), " data.root=" + root + " data.hand=both train.densify.grad_threshold=1e-6");
  check_same_state(single, ranks);
  CHECK(ranks.tensors.count("left/gaussians/means") == 1);
}

TEST_CASE("train: data parallel: pose refinement on 2 ranks equals 1 process x batch_size 2") {
  // Every rank applies every rank's pose-correction updates, in the single process's order.
  const auto dir = fresh_dir("dp_pose_refine");
  const auto [a, b] = train_single_and_two_ranks(
      dir, " train.densify.enabled=false train.pose_refine.enabled=true train.pose_refine.start=2");
  REQUIRE(a.tensors.count("pose_refine/values") == 1);
  // Both views' poses were corrected: more than one row moved.
  CHECK((a.tensors.at("pose_refine/values").abs().sum(1) > 0).sum().item<int64_t>() >= 2);
  check_same_state(a, b);
}

TEST_CASE("train: data parallel: per-camera colour transforms on 2 ranks equal 1 process x batch_size 2") {
  // The transforms are one more optimiser group: their gradients travel in the step's all-reduce,
  // and every rank projects the same values (mean at the identity).
  const auto dir = fresh_dir("dp_camera_color");
  const auto [a, b] = train_single_and_two_ranks(
      dir, " train.densify.enabled=false train.camera_color=gain train.lr.camera_color=0.01");
  REQUIRE(a.tensors.count("camera_color/params") == 1);
  CHECK(a.tensors.at("camera_color/params").abs().max().item<double>() > 0);
  check_same_state(a, b);
}

TEST_CASE("train: data parallel: a 2-rank run resumed with 2 ranks repeats the uninterrupted run") {
  // Rank 0's checkpoints hold every rank's inter-pose chains (gathered at each checkpoint), so
  // after the resume rank 1's first step has its L_con as in the uninterrupted run. No
  // densification: it would reset the chains near the resume and hide the difference.
  const auto dir = fresh_dir("dp_resume_exact");
  std::filesystem::create_directories(dir);
  const auto straight = dir + "/straight", resumed = dir + "/resumed";
  // The same run stopped after its step-6 checkpoint: a copy of the folder without the later one
  // (stopping the run itself at 6 would change its learning-rate schedule).
  const std::string plain = " train.densify.enabled=false train.log_every=1 train.checkpoint_every=6";
  REQUIRE(run_two_ranks(train_command(straight) + plain, rank1_command(straight), dir + "/straight.log") == 0);
  std::filesystem::copy(straight, resumed, std::filesystem::copy_options::recursive);
  REQUIRE(std::filesystem::remove(resumed + "/checkpoints/step_00000012.ckpt"));
  const int rc = run_two_ranks(kBin + "/handscs-train --resume --out " + resumed + " --threads 1", rank1_command(resumed),
                               dir + "/second.log");
  INFO(handscs::read_file(dir + "/second.log.0") + handscs::read_file(dir + "/second.log.1"));
  REQUIRE(rc == 0);
  const auto a = handscs::load_checkpoint(handscs::latest_checkpoint(straight));
  const auto b = handscs::load_checkpoint(handscs::latest_checkpoint(resumed));
  REQUIRE(b.meta["iteration"] == 12);
  CHECK(a.tensors.count("consistency/view1/descriptor") == 1);  // rank 1's chain, in rank 0's file
  const auto difference = handscs_test::compare_checkpoints(a, b);
  CHECK(difference.mismatch == "");
  INFO("largest relative difference " << difference.worst << " in " << difference.worst_name);
  CHECK(difference.worst == 0.0);
  // The logged losses of steps 7-12 (L_con included) are the same numbers.
  const auto log_a = handscs::read_csv(straight + "/metrics.csv"), log_b = handscs::read_csv(resumed + "/metrics.csv");
  REQUIRE(log_a.rows.size() == 12);
  REQUIRE(log_b.rows.size() == 12);
  for (size_t row = 6; row < 12; ++row) {
    INFO("step " << row + 1);
    CHECK(log_a.at(row, "loss") == log_b.at(row, "loss"));
    CHECK(log_a.at(row, "consistency") == log_b.at(row, "consistency"));
  }
}

TEST_CASE("train: data parallel: a killed rank ends the other with a clear error within the timeout") {
  const auto dir = fresh_dir("dp_kill");
  std::filesystem::create_directories(dir);
  const int port = free_port();
  // Rank 1 is killed (SIGKILL) once both are training (rank 0 writes metrics.csv at its first
  // logged step, after the rendezvous and several exchanges); rank 0 must exit non-zero on its own,
  // well within the 30 s timeout (a dead peer closes its connection at once).
  const std::string long_run = train_command(dir + "/run") + " train.iterations=100000 --dist-timeout 30";
  const auto [rc, seconds] = timed_shell(rank_env(0, port) + long_run + " > " + dir + "/log0 2>&1 & p0=$!; " +
                       rank_env(1, port) + rank1_command(dir + "/run") + " > " + dir + "/log1 2>&1 & p1=$!; "
                       "for i in $(seq 150); do test -e " + dir +
                       "/run/metrics.csv && break; sleep 0.2; done; "
                       "sleep 1; kill -9 $p1; wait $p0");
  const auto log = handscs::read_file(dir + "/log0");
  INFO(log);
  CHECK(rc == 1);
  CHECK(seconds < 30);
  CHECK(log.find("data parallel, rank 0 of 2") != std::string::npos);
  CHECK(log.find("another rank died") != std::string::npos);
}

TEST_CASE("train: data parallel: a rank whose peers never come fails its rendezvous with a clear error") {
  const auto dir = fresh_dir("dp_alone");
  const auto [rc, seconds] =
      timed_shell(rank_env(1, free_port()) + rank1_command(dir) + " --dist-timeout 2 > " + dir + ".log 2>&1");
  const auto log = handscs::read_file(dir + ".log");
  INFO(log);
  CHECK(rc == 1);
  CHECK(seconds < 30);
  CHECK(log.find("no rendezvous with the other ranks") != std::string::npos);
}

TEST_CASE("train: data parallel: a 2-rank run resumes with 1 rank, and a 1-rank run with 2") {
  const auto dir = fresh_dir("dp_resume");
  std::filesystem::create_directories(dir);
  const auto run = dir + "/run";
  REQUIRE(run_two_ranks(train_command(run), rank1_command(run),
                        dir + "/first.log") == 0);
  CHECK(handscs::latest_checkpoint(run).find("step_00000012.ckpt") != std::string::npos);
  const std::string resume = kBin + "/handscs-train --resume --out " + run + " --threads 1 --set ";
  REQUIRE(shell(resume + "train.iterations=16 > " + dir + "/one.log 2>&1") == 0);
  CHECK(handscs::read_file(dir + "/one.log").find("resumed from") != std::string::npos);
  CHECK(handscs::latest_checkpoint(run).find("step_00000016.ckpt") != std::string::npos);
  const int rc = run_two_ranks(resume + "train.iterations=20",
                               rank1_command(run), dir + "/two.log");
  INFO(handscs::read_file(dir + "/two.log.0") + handscs::read_file(dir + "/two.log.1"));
  REQUIRE(rc == 0);
  CHECK(handscs::latest_checkpoint(run).find("step_00000020.ckpt") != std::string::npos);
  // The run folder is rank 0's alone: one metrics row per logged step, no duplicates.
  std::ifstream csv(run + "/metrics.csv");
  std::string line;
  std::set<std::string> steps;
  int rows = 0;
  std::getline(csv, line);
  while (std::getline(csv, line)) {
    ++rows;
    steps.insert(line.substr(0, line.find(',')));
  }
  CHECK(rows == static_cast<int>(steps.size()));
  CHECK(steps == std::set<std::string>{"10", "20"});
}

TEST_CASE("train: data parallel: a NaN on one rank is skipped by both, then both roll back") {
  auto config = handscs_test::tiny_run_config();
  config.train.max_bad_steps = 3;
  struct RankRecord {
    std::vector<handscs::StepResult> results;  // steps 5, 6, 7 (poisoned) and 8
    torch::Tensor good_means, means_after_rollback;
  };
  RankRecord records[2];
  const auto errors = run_rank_threads([&](handscs::ProcessGroup& group, int rank) {
    handscs::Trainer trainer(config, fresh_dir("dp_nan_" + std::to_string(rank)), &group);
    for (int i = 0; i < 4; ++i) trainer.step();
    if (rank == 0) trainer.save_checkpoint();  // what the rollback returns to
    records[rank].good_means = trainer.avatar().gaussians().means.detach().clone();
    if (rank == 1) {
      torch::NoGradGuard no_grad;
      trainer.avatar().gaussians().means[0][0] = NAN;  // rank 1's gradients only
    }
    for (int i = 0; i < 3; ++i) records[rank].results.push_back(trainer.step());
    records[rank].means_after_rollback = trainer.avatar().gaussians().means.detach().clone();
    records[rank].results.push_back(trainer.step());
  });
  for (int rank = 0; rank < 2; ++rank) {
    INFO("rank " << rank);
    REQUIRE(errors[rank] == "");
    const auto& r = records[rank].results;
    REQUIRE(r.size() == 4);
    CHECK(r[0].skipped);  // rank 0's own gradients were finite: skipped because rank 1's were not
    CHECK(r[1].skipped);
    CHECK(r[2].skipped);
    CHECK(r[2].rolled_back);
    CHECK(r[2].iteration == 4);
    CHECK_FALSE(r[3].skipped);
    CHECK(std::isfinite(r[3].loss));
    // Both ranks hold the checkpoint's parameters again, rank 1 by receiving rank 0's state.
    CHECK(torch::equal(records[rank].means_after_rollback, records[0].good_means));
  }
}

TEST_CASE("train: data parallel: named slots sum across ranks whatever order each rank adds them") {
  struct RankRecord {
    torch::Tensor grid, count;
    double loss = 0;
    bool finite = false;
  };
  RankRecord records[2];
  const auto errors = run_rank_threads([&](handscs::ProcessGroup& group, int rank) {
    handscs::ReduceSlots slots;
    const auto grid = torch::arange(6, torch::kFloat32).view({2, 3}) * (rank + 1);
    const auto count = torch::full({4}, double(10 * (rank + 1)));
    if (rank == 0) {  // rank 0 adds in one order, rank 1 in the reverse
      slots.add("b/grid", grid);
      slots.add("a/count", count);
      slots.add_scalar("loss", 0.25);
    } else {
      slots.add_scalar("loss", 0.5);
      slots.add("a/count", count);
      slots.add("b/grid", grid);
    }
    slots.all_reduce(group);
    records[rank] = {slots.get("b/grid").clone(), slots.get("a/count").clone(),
                     slots.scalar("loss"), slots.all_finite()};
  });
  for (int rank = 0; rank < 2; ++rank) {
    INFO("rank " << rank);
    REQUIRE(errors[rank] == "");
    // rank 0 holds 0..5, rank 1 twice that: the sum is three times 0..5, shaped as added.
    CHECK(torch::equal(records[rank].grid, torch::arange(6, torch::kFloat32).view({2, 3}) * 3));
    CHECK(torch::equal(records[rank].count, torch::full({4}, 30.0)));
    CHECK(records[rank].loss == 0.75);
    CHECK(records[rank].finite);
  }
}
