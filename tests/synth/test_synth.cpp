// The synthetic capture generator: presets, determinism (seed, thread count), the range-of-motion
// sequence, the skin and background it renders, and an interrupted run that leaves nothing behind.
#include <omp.h>
#include <signal.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <opencv2/core.hpp>

#include "core/atomic_file.h"
#include "core/available_memory.h"
#include "core/config.h"
#include "core/threads.h"
#include "hand/lbs.h"
#include "synth/capture.h"
#include "synth/math.h"
#include "synth/render_memory.h"
#include "test_support.h"
#include "data/data_test_helpers.h"

// Catch last: LibTorch pulls in glog, whose CHECK macro would otherwise replace Catch's.
#include <catch2/catch.hpp>

using namespace handscs;
using namespace handscs::synth;  // Vec3 operators
namespace fs = std::filesystem;

TEST_CASE("synth: presets and unknown names") {
  const SynthConfig tiny = synth_preset("tiny");
  CHECK(tiny.num_cameras * tiny.num_frames == 48);
  const SynthConfig demo = synth_preset("demo");
  CHECK(demo.num_cameras == 12);
  CHECK(demo.num_frames == 100);
  CHECK(demo.width == 334);
  CHECK(demo.height == 512);
  const SynthConfig bench = synth_preset("bench");
  CHECK(bench.num_cameras * bench.num_frames == 3600);
  CHECK(data_test::error_of([] { synth_preset("huge"); }) ==
        "--preset: unknown preset \"huge\" (known: tiny, demo, bench, paper, both_tiny, both_demo, "
        "both_bench, both_paper, real_tiny, real_demo, real_bench, real_paper, real_both_tiny, "
        "real_both_demo, real_both_bench, real_both_paper)");
  // The paper's scale: 350 training poses, and 25 colour cameras for 10 training + 15 test views.
  const SynthConfig paper = synth_preset("real_paper");
  CHECK(paper.num_frames - paper.held_out_frames == 350);
  CHECK(paper.num_cameras - paper.num_cameras / paper.effects.monochrome_every == 25);
  // The settings round-trip through JSON (config visitor).
  SynthConfig back;
  SynthConfig copy = bench;
  config_from_json(config_to_json(copy), "synth.json", back);
  CHECK(back.num_frames == 150);
  CHECK(back.preset == "bench");
}

TEST_CASE("synth: docs/CONFIG.md documents every handscs-synth key") {
  SynthConfig defaults = synth_preset("tiny");
  const std::string doc = read_file(std::string(HANDSCS_SOURCE_DIR) + "/docs/CONFIG.md");
  // Regenerate the table with: build/bin/handscs-synth --print-docs
  CHECK(doc.find("## handscs-synth\n") != std::string::npos);
  CHECK(doc.find(config_markdown(defaults)) != std::string::npos);
}

TEST_CASE("synth: output is a function of the seed, not of the thread count") {
  SynthConfig config = synth_preset("tiny");
  config.num_frames = 4;
  config.num_cameras = 2;
  const std::string one = data_test::fresh_dir("synth_threads_1"),
                    two = data_test::fresh_dir("synth_threads_2");
  const int threads = omp_get_max_threads();
  handscs::set_threads(1);  // LibTorch and OpenMP, as handscs-synth --threads
  write_synth_capture(make_synth_scene(config), one);
  handscs::set_threads(2);  // LibTorch and OpenMP, as handscs-synth --threads
  write_synth_capture(make_synth_scene(config), two);
  handscs::set_threads(threads);  // LibTorch and OpenMP, as handscs-synth --threads
  int files = 0;
  for (const auto& entry : fs::recursive_directory_iterator(one)) {
    if (!entry.is_regular_file()) continue;
    const fs::path other = fs::path(two) / fs::relative(entry.path(), one);
    INFO(entry.path());
    REQUIRE(fs::exists(other));
    CHECK(read_file(entry.path().string()) == read_file(other.string()));
    ++files;
  }
  CHECK(files == 4 * 2 + 4 + 2);  // images, the four annotation files, synth.json, frames.csv
  config.seed = 2;
  const SynthScene other_seed = make_synth_scene(config);
  const SynthScene same_seed = make_synth_scene(synth_preset("tiny"));
  CHECK(other_seed.frames[1].absolute.pose != same_seed.frames[1].absolute.pose);
  CHECK(other_seed.cameras[0].raw.campos_mm != same_seed.cameras[0].raw.campos_mm);
}

TEST_CASE("synth: range of motion is smooth, anatomical and varies shape slightly") {
  const SynthScene scene = make_synth_scene(synth_preset("demo"));
  const auto& frames = scene.frames;
  const torch::Tensor mean = scene.rig.hands_mean.to(torch::kFloat64).contiguous();
  double max_step = 0, max_global = 0, max_flex = 0;
  std::array<double, 10> shape_mean{};
  for (const auto& f : frames)
    for (int i = 0; i < 10; ++i) shape_mean[i] += f.absolute.shape[i] / frames.size();
  for (size_t k = 0; k < frames.size(); ++k) {
    // Written pose = absolute pose - hands_mean on the 45 finger values.
    for (int i = 0; i < 45; ++i)
      CHECK(frames[k].annotated[3 + i] ==
            Approx(frames[k].absolute.pose[3 + i] - mean[i].item<double>()));
    for (int j = 0; j < 16; ++j) {
      const synth::Vec3 a = {frames[k].absolute.pose[j * 3], frames[k].absolute.pose[j * 3 + 1],
                             frames[k].absolute.pose[j * 3 + 2]};
      if (j == 0)
        max_global = std::max(max_global, synth::norm(a));
      else
        max_flex = std::max(max_flex, synth::norm(a));
      if (k > 0) {
        const synth::Vec3 b = {frames[k - 1].absolute.pose[j * 3],
                               frames[k - 1].absolute.pose[j * 3 + 1],
                               frames[k - 1].absolute.pose[j * 3 + 2]};
        max_step = std::max(max_step, synth::norm(a - b));
      }
    }
    for (int i = 0; i < 10; ++i)
      CHECK(std::fabs(frames[k].absolute.shape[i] - shape_mean[i]) < 0.2);
  }
  CHECK(max_step < 0.4);    // rad between consecutive frames: smooth at 30 frames per cycle
  CHECK(max_global > 0.3);  // the wrist rotates
  CHECK(max_flex > 1.0);    // fingers flex far
  CHECK(max_flex < 1.6);    // but within the human range
  CHECK(frames[0].absolute.shape != frames[1].absolute.shape);
}

TEST_CASE("synth: frames posed in chunks equal each frame posed alone") {
  // LBS runs over 512 frames at a time (its per-vertex intermediates would take gigabytes for
  // tens of thousands of frames at once); frames on either side of a chunk boundary and the last
  // one are posed again alone and must agree to rounding (BLAS sums a batch of 1 and of 512 in
  // different orders: the joints differ in the last bits of a double, ~1e-17 m).
  SynthConfig config = synth_preset("tiny");
  config.num_frames = 1100;
  config.num_sequences = 2;
  const SynthScene scene = make_synth_scene(config);
  handscs::LbsOptions options;
  options.flat_hand_mean = true;
  const auto f64 = torch::TensorOptions().dtype(torch::kFloat64);
  for (int64_t k : {0, 511, 512, 1023, 1024, 1099}) {
    const auto& frame = scene.frames[k];
    const torch::Tensor pose = torch::tensor(std::vector<double>(frame.absolute.pose.begin(),
                                                                 frame.absolute.pose.end()), f64).view({1, 48});
    const torch::Tensor shape = torch::tensor(std::vector<double>(frame.absolute.shape.begin(),
                                                                  frame.absolute.shape.end()), f64).view({1, 10});
    torch::NoGradGuard no_grad;
    const auto alone = handscs::lbs(scene.rig, pose, shape, torch::zeros({1, 3}, f64), options);
    const auto joints = alone.joints[0].contiguous();
    INFO(k);
    for (int i = 0; i < 63; ++i)
      CHECK(std::fabs(frame.joints[i] - (joints.data_ptr<double>()[i] + frame.trans[i % 3])) < 1e-12);
  }
}

TEST_CASE("synth: skin detail, pose-dependent shading and a dark noisy background") {
  const SynthScene scene = make_synth_scene(synth_preset("tiny"));
  const SynthSkin& skin = scene.skin;
  // A dorsal PIP wrinkle is darker than the skin 4 mm along the finger (between wrinkles).
  const size_t pip = 3 * 1 + 1;  // index finger, second joint
  REQUIRE(skin.crease_kind[pip] == 1);
  int darker = 0;
  for (int k = 0; k < 20; ++k) {
    const synth::Vec3 offset =
        skin.palm_back * (0.004 + 0.0005 * k);  // towards the back of the hand
    const synth::Vec3 on = skin.crease_centre[pip] + offset;
    const synth::Vec3 off = on + skin.crease_axis[pip] * 0.004;
    darker += skin_albedo(skin, on, 0, 0)[1] < 0.95 * skin_albedo(skin, off, 0, 0)[1];
  }
  CHECK(darker >= 18);
  // Nails differ from skin.
  const synth::Vec3 p = skin.crease_centre[pip];
  const synth::Vec3 nail = skin_albedo(skin, p, 1, 0), plain = skin_albedo(skin, p, 0, 0);
  CHECK(std::fabs(nail[2] - plain[2]) > 0.1);

  const SynthView a = render_synth_frame(scene, 0, 0), b = render_synth_frame(scene, 6, 0);
  const cv::Scalar hand_a = cv::mean(a.bgr, a.coverage), hand_b = cv::mean(b.bgr, b.coverage);
  CHECK(std::fabs(hand_a[2] - hand_b[2]) + std::fabs(hand_a[1] - hand_b[1]) > 1.0);
  cv::Scalar bg_mean, bg_std;
  cv::meanStdDev(a.bgr, bg_mean, bg_std, a.samples == 0);
  for (int c = 0; c < 3; ++c) {
    CHECK(bg_mean[c] < 12);
    CHECK(bg_std[c] > 0.5);
    CHECK(bg_std[c] < 3);
  }
  CHECK(cv::countNonZero(a.coverage) > 1500);
  // Same frame, same pixels.
  const SynthView again = render_synth_frame(scene, 0, 0);
  CHECK(cv::countNonZero(again.bgr.reshape(1) != a.bgr.reshape(1)) == 0);
}

TEST_CASE("synth: a folder that is not empty is refused, and replaced only by a complete capture") {
  const std::string dir = data_test::fresh_dir("synth_replace");
  fs::create_directories(dir);
  write_file_atomic(dir + "/mine.txt", "a user's file");
  SynthConfig config = synth_preset("tiny");
  config.num_frames = 4;
  config.held_out_frames = 1;
  CHECK(data_test::error_of([&] { generate_synth_capture(config, dir); }) ==
        dir + ": not empty (mine.txt); choose another --out, or replace it with --overwrite");
  CHECK(read_file(dir + "/mine.txt") == "a user's file");

  // A capture that fails while it is made (here: more sequences than frames) leaves the folder
  // as it was, and no staging folder beside it.
  SynthConfig broken = config;
  broken.num_sequences = 5;
  CHECK(data_test::error_of([&] { generate_synth_capture(broken, dir, /*overwrite=*/true); }) ==
        "synth: num_sequences must be in [1, num_frames]");
  CHECK(read_file(dir + "/mine.txt") == "a user's file");
  int siblings = 0;
  for (const auto& entry : fs::directory_iterator(fs::path(dir).parent_path()))
    siblings += entry.path().filename().string().rfind(fs::path(dir).filename().string() + ".synth-",
                                                       0) == 0;
  CHECK(siblings == 0);

  // --overwrite with a capture that completes: the folder holds exactly the new capture.
  generate_synth_capture(config, dir, /*overwrite=*/true);
  CHECK_FALSE(fs::exists(dir + "/mine.txt"));
  CHECK(fs::exists(dir + "/annotations/test/InterHand2.6M_test_data.json"));
  int images = 0;
  for (const auto& entry : fs::recursive_directory_iterator(dir + "/images"))
    images += entry.path().extension() == ".jpg";
  CHECK(images == 4 * config.num_cameras);

  // Sizes beyond any InterHand2.6M capture are refused before anything is allocated.
  SynthConfig huge = synth_preset("tiny");
  huge.num_cameras = 1000;
  huge.num_frames = 100000;
  CHECK(data_test::error_of([&] { generate_synth_capture(huge, dir + "_huge"); }) ==
        "num_cameras x num_frames: 100000000 images (at most 5000000)");
  CHECK_FALSE(fs::exists(dir + "_huge"));
}

TEST_CASE("synth: a capture this machine cannot hold is refused before rendering, with the estimate") {
  SynthConfig big = synth_preset("tiny");
  big.width = big.height = 8192;  // inside the documented ranges, and under 100 megapixels
  // Per image: 30 bytes a pixel (67.1 M) and 20 a sub-sample of the hand's rectangle (its side
  // 0.19 m x 1265 x 8192 / 334 / 1.05 m = 5614 px, 3 x 3 sub-samples a pixel): 7.69 GB.
  const int64_t one = synth_render_bytes(big, 1);
  CHECK(one == Approx(30 * 67108864.0 + 20 * 9 * 5614.3 * 5614.3).epsilon(1e-3));
  CHECK(synth_render_bytes(big, 2) == 2 * one);  // an image a thread, rendered at once
  SynthConfig single = big;
  single.num_cameras = single.num_frames = 1;
  CHECK(synth_render_bytes(single, 2) == one);  // no more images at once than the capture has
  SynthConfig plain = big;
  plain.supersample = 1;
  CHECK(synth_render_bytes(plain, 1) < one / 2);
  // The available memory is given, so the refusal does not depend on this machine.
  CHECK(data_test::error_of([&] { check_synth_memory(big, 2, 4'000'000'000); }) ==
        "synth: rendering 8192 x 8192 images at supersample 3 (2 at once: --threads) needs about "
        "15.4 GB, more than the 4.0 GB this machine has available; lower width and height, "
        "supersample or --threads");
  CHECK(data_test::error_of([&] { check_synth_memory(big, 2, 16'000'000'000); }) == "(no error)");
  CHECK(data_test::error_of([&] { check_synth_memory(big, 2, -1); }) == "(no error)");  // not known
  CHECK(synth_render_bytes(synth_preset("tiny"), 2) < 8'000'000);  // the CI capture: 7.3 MB

  // The generator asks before it writes: 53 GB an image at supersample 9, on 8 threads.
  const std::string dir = data_test::fresh_dir("synth_no_memory") + "/capture";
  big.supersample = 9;
  const int threads = omp_get_max_threads();
  omp_set_num_threads(8);
  REQUIRE(synth_render_bytes(big, 8) > available_memory_bytes());
  const std::string error = data_test::error_of([&] { generate_synth_capture(big, dir); });
  omp_set_num_threads(threads);
  CHECK(error.rfind("synth: rendering 8192 x 8192 images at supersample 9 (8 at once: --threads) needs "
                    "about 424.6 GB, more than the ",
                    0) == 0);
  CHECK_FALSE(fs::exists(dir));
}

TEST_CASE("synth: an --out that is a file is named as one, with or without --overwrite") {
  const std::string file = data_test::fresh_dir("synth_file") + "/notes.txt";
  write_file_atomic(file, "a user's file");
  SynthConfig config = synth_preset("tiny");
  config.num_frames = 4;
  config.held_out_frames = 1;
  const std::string expected =
      file + ": is a file, not a folder; choose another --out (--overwrite replaces only a folder)";
  CHECK(data_test::error_of([&] { generate_synth_capture(config, file); }) == expected);
  CHECK(data_test::error_of([&] { generate_synth_capture(config, file, /*overwrite=*/true); }) == expected);
  CHECK(read_file(file) == "a user's file");
}

TEST_CASE("synth: SIGTERM drops the unfinished capture and leaves the folder as it was") {
  const std::string dir = handscs_test::scratch_path("handscs_test_synth_stop", "case");
  fs::remove_all(dir);
  fs::create_directories(dir + "/out");
  { std::ofstream(dir + "/out/keep.txt") << "the user's"; }  // --overwrite: replaced only when complete
  const pid_t child = handscs_test::spawn(handscs_test::kBin + "/handscs-synth --preset demo --threads 1 "
                                          "--overwrite --out " + dir + "/out > " + dir + "/synth.log 2>&1");
  REQUIRE(child > 0);
  // Once the first image is in the staging folder (the handler is installed before any), stop it.
  const std::string staging = dir + "/out.synth-new." + std::to_string(child);
  REQUIRE(handscs_test::wait_until([&] {
    std::error_code ec;
    for (const auto& entry : fs::recursive_directory_iterator(staging, ec))
      if (entry.path().extension() == ".jpg") return true;
    return false;
  }));
  kill(child, SIGTERM);
  CHECK(handscs_test::exit_code_of(child) == 1);
  const std::string log = handscs::read_file(dir + "/synth.log");
  CHECK(log.find("synth: interrupted (SIGINT, SIGTERM or SIGHUP) after ") != std::string::npos);
  CHECK(log.find("images, before the capture was complete") != std::string::npos);
  CHECK_FALSE(fs::exists(staging));
  int entries = 0;
  for ([[maybe_unused]] const auto& entry : fs::directory_iterator(dir + "/out")) ++entries;
  CHECK(entries == 1);  // keep.txt, as it was
}
