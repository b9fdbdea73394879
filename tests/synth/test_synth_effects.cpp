// The realistic capture's effects (synth/effects.h): each one switched on and off changes the images
// where, and only where, it should; the annotations carry the configured fit error while joint_3d
// stays the truth; gestures move the fingers independently and hold out unseen articulations;
// region masks cover what they claim; the output is the same on any thread count.
#include <omp.h>

#include <cmath>
#include <filesystem>
#include <set>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "core/atomic_file.h"
#include "core/csv_table.h"
#include "core/threads.h"
#include "data/capture.h"
#include "data/data_test_helpers.h"
#include "hand/joint_order.h"
#include "hand/lbs.h"
#include "synth/capture.h"
#include "synth/gestures.h"
#include "synth/math.h"
#include "synth/regions.h"
#include "synth/tissue.h"

// Catch last: LibTorch pulls in glog, whose CHECK macro would otherwise replace Catch's.
#include <catch2/catch.hpp>

using namespace handscs;
using namespace handscs::synth;  // Vec3 operators
namespace fs = std::filesystem;

namespace {

// The tiny size with no effect on (not even the old ambient occlusion) unless turned on.
SynthConfig bare_tiny() {
  SynthConfig config = synth_preset("tiny");
  config.effects = SynthEffects{};
  config.effects.ambient_occlusion = false;
  return config;
}

// Pixels (any channel) differing by more than `levels` between two renders.
cv::Mat changed(const SynthView& a, const SynthView& b, int levels) {
  cv::Mat diff;
  cv::absdiff(a.bgr, b.bgr, diff);
  std::vector<cv::Mat> planes;
  cv::split(diff, planes);
  cv::Mat most = cv::max(cv::max(planes[0], planes[1]), planes[2]);
  return most > levels;
}

cv::Mat region(const SynthView& v, uint8_t bit) { return (v.regions & bit) > 0; }

cv::Mat grow(const cv::Mat& mask, int px) {
  cv::Mat out;
  cv::dilate(mask, out, cv::Mat::ones(2 * px + 1, 2 * px + 1, CV_8UC1));
  return out;
}

}  // namespace

TEST_CASE("synth effects: realistic presets turn every effect on, and --set turns one off") {
  const SynthConfig real = synth_preset("real_demo"), easy = synth_preset("demo");
  CHECK(real.num_frames == easy.num_frames);
  CHECK(real.num_cameras == easy.num_cameras);
  const SynthEffects& e = real.effects;
  CHECK((e.tissue && e.fit_error && e.flexion_skin && e.cast_shadows && e.gestures && e.forearm &&
         e.camera_response && e.region_masks && e.monochrome_every > 0));
  const SynthEffects& o = easy.effects;
  CHECK(!(o.tissue || o.fit_error || o.flexion_skin || o.cast_shadows || o.gestures || o.forearm ||
          o.camera_response || o.region_masks));
  const SynthConfig off = apply_synth_overrides(real, {"effects.cast_shadows=false"});
  CHECK(!off.effects.cast_shadows);
  CHECK(off.effects.tissue);
  CHECK(data_test::error_of([&] { apply_synth_overrides(real, {"effects.shadows=false"}); })
            .find("effects.shadows") != std::string::npos);
}

TEST_CASE("synth effects: annotations carry smooth fit error of the configured size") {
  SynthConfig config = synth_preset("demo");
  config.num_cameras = 1;
  config.effects.fit_error = true;
  const SynthScene scene = make_synth_scene(config);
  const torch::Tensor mean = scene.rig.hands_mean.to(torch::kFloat64).contiguous();
  const double* m = mean.data_ptr<double>();
  double finger_sq = 0, global_sq = 0, trans_sq = 0, step_sq = 0, shape_sq = 0;
  int finger_n = 0, steps = 0;
  std::array<double, 48> previous{};
  for (size_t k = 0; k < scene.frames.size(); ++k) {
    const SynthFrame& f = scene.frames[k];
    std::array<double, 48> error{};
    for (int i = 0; i < 48; ++i)
      error[i] = f.annotated[i] + (i >= 3 ? m[i - 3] : 0.0) - f.absolute.pose[i];
    for (int i = 0; i < 3; ++i) global_sq += error[i] * error[i];
    for (int i = 3; i < 48; ++i) finger_sq += error[i] * error[i];
    finger_n += 15;
    for (int d = 0; d < 3; ++d) {
      const double e = f.annotated_trans[d] - f.trans[d];
      trans_sq += e * e;
    }
    for (int i = 0; i < 10; ++i)
      shape_sq += std::pow(f.annotated_shape[i] - f.absolute.shape[i], 2) / 10;
    if (k > 0)
      for (int i = 3; i < 48; ++i) step_sq += std::pow(error[i] - previous[i], 2), ++steps;
    previous = error;
  }
  const double frames = static_cast<double>(scene.frames.size());
  const double deg = M_PI / 180;
  // RMS rotation error per joint (the error vector's length) and per translation vector.
  const double finger_rms = std::sqrt(finger_sq / finger_n) / deg;
  const double global_rms = std::sqrt(global_sq / frames) / deg;
  const double trans_rms = std::sqrt(trans_sq / frames) * 1000;
  const double shape_rms = std::sqrt(shape_sq / frames);
  CHECK(finger_rms == Approx(config.effects.fit_pose_deg).epsilon(0.2));
  CHECK(global_rms == Approx(config.effects.fit_global_deg).epsilon(0.35));
  CHECK(trans_rms == Approx(config.effects.fit_trans_mm).epsilon(0.35));
  CHECK(shape_rms == Approx(config.effects.fit_shape).epsilon(0.35));
  // Smooth in time: a frame-to-frame change well below the error itself.
  CHECK(std::sqrt(step_sq / steps) < 0.7 * std::sqrt(finger_sq / finger_n / 3));
  // joint_3d is the rendered truth: LBS of the absolute pose and shape at the rendered trans.
  const SynthFrame& f = scene.frames[37];
  const auto options = torch::TensorOptions().dtype(torch::kFloat64);
  torch::Tensor pose = torch::from_blob(const_cast<double*>(f.absolute.pose.data()), {1, 48},
                                        options).clone();
  torch::Tensor shape = torch::from_blob(const_cast<double*>(f.absolute.shape.data()), {1, 10},
                                         options).clone();
  torch::Tensor trans = torch::from_blob(const_cast<double*>(f.trans.data()), {1, 3}, options).clone();
  LbsOptions lbs_options;
  lbs_options.flat_hand_mean = true;
  const torch::Tensor joints = lbs(scene.rig, pose, shape, trans, lbs_options).joints[0].contiguous();
  for (int i = 0; i < 63; ++i) CHECK(f.joints[i] == Approx(joints.data_ptr<double>()[i]).margin(1e-9));
}

TEST_CASE("synth effects: tissue moves the skin by millimetres, only near flexed joints") {
  const Rig rig = load_rig_source("builtin");
  const HandAxes axes = rig_axes(rig);
  const TissueRig tissue = make_tissue_rig(rig, axes);
  SynthEffects effects;
  effects.contact_max_mm = 0;  // bending alone
  const torch::Tensor vt = rig.v_template.to(torch::kFloat32).contiguous();
  std::vector<float> vertices(vt.data_ptr<float>(), vt.data_ptr<float>() + vt.numel());
  std::vector<int64_t> faces;
  {
    const torch::Tensor f = rig.faces.to(torch::kInt64).contiguous();
    faces.assign(f.data_ptr<int64_t>(), f.data_ptr<int64_t>() + f.numel());
  }
  const std::vector<float> normals = vertex_normals(vertices, faces);
  HandArticulation flat;
  const TissueResult none = tissue_displacement(tissue, effects, flat, vertices, normals);
  for (float d : none.displacement) REQUIRE(d == 0.0f);
  // Only the index PIP flexes, by a right angle: skin moves within ~2 cm of that joint only.
  HandArticulation bent;
  bent.flex[kIndex][1] = M_PI / 2;
  const TissueResult result = tissue_displacement(tissue, effects, bent, vertices, normals);
  const synth::Vec3 pip = tissue.joints[kFingerJoints[kIndex][1]];
  double largest = 0, largest_far = 0;
  for (size_t i = 0; i < result.displacement.size(); ++i) {
    const double d = std::fabs(result.displacement[i]);
    largest = std::max(largest, d);
    if (synth::norm(tissue.rest[i] - pip) > 0.02) largest_far = std::max(largest_far, d);
  }
  CHECK(largest > 0.001);   // at least a millimetre: the knuckle and the flexed side
  CHECK(largest < 0.004);   // at most a few
  CHECK(largest_far < 1e-5);
  // Contact: two parts facing each other within the radius are flattened, nothing else.
  effects.contact_max_mm = 2;
  const TissueResult contact = tissue_displacement(tissue, effects, flat, vertices, normals);
  for (size_t i = 0; i < contact.contact.size(); ++i) {
    CHECK(contact.contact[i] >= 0);
    CHECK(contact.contact[i] <= 0.002 + 1e-9);
  }
}

TEST_CASE("synth effects: each effect changes the image only where it should") {
  SynthConfig base = bare_tiny();
  base.effects.gestures = true;  // fingers bent and touching in some frames
  const SynthScene plain = make_synth_scene(base);
  const int frame = 5, camera = 0;
  const SynthView reference = render_synth_frame(plain, frame, camera);
  const cv::Mat hand = grow(reference.samples > 0, 2);

  SECTION("cast shadows darken lit skin, inside the shadow region") {
    SynthConfig config = base;
    config.effects.cast_shadows = true;
    const SynthScene scene = make_synth_scene(config);
    const SynthView view = render_synth_frame(scene, frame, camera);
    const cv::Mat moved = changed(view, reference, 10);
    CHECK(cv::countNonZero(moved) > 20);
    CHECK(cv::countNonZero(moved & ~grow(region(view, kRegionShadow), 1)) == 0);
    cv::Mat lighter;
    cv::compare(view.bgr.reshape(1), reference.bgr.reshape(1), lighter, cv::CMP_GT);
    CHECK(cv::countNonZero(lighter) == 0);  // a shadow never brightens
  }
  SECTION("flexion creases change the skin inside the crease region") {
    SynthConfig config = base;
    config.effects.flexion_skin = true;
    const SynthScene scene = make_synth_scene(config);
    const SynthView view = render_synth_frame(scene, frame, camera);
    const cv::Mat moved = changed(view, reference, 6);
    CHECK(cv::countNonZero(moved) > 10);
    CHECK(cv::countNonZero(moved & ~grow(region(view, kRegionCrease), 1)) == 0);
  }
  SECTION("tissue changes pixels of the hand only") {
    SynthConfig config = base;
    config.effects.tissue = true;
    const SynthScene scene = make_synth_scene(config);
    const SynthView view = render_synth_frame(scene, frame, camera);
    const cv::Mat moved = changed(view, reference, 3);
    CHECK(cv::countNonZero(moved) > 10);
    CHECK(cv::countNonZero(moved & ~hand) == 0);
    // The annotations (and so the MANO masks) do not see the tissue.
    CHECK(scene.frames[frame].annotated == plain.frames[frame].annotated);
  }
  SECTION("the forearm appears outside the hand, and nothing else changes") {
    SynthConfig config = base;
    config.effects.forearm = true;
    const SynthScene scene = make_synth_scene(config);
    const SynthView view = render_synth_frame(scene, frame, camera);
    const cv::Mat moved = changed(view, reference, 6);
    const int outside = cv::countNonZero(moved & ~(reference.samples > 0));
    CHECK(outside > 300);
    // Inside the hand it can only hide the wrist end, which it overlaps by 12 mm.
    CHECK(outside > 0.8 * cv::countNonZero(moved));
  }
  SECTION("camera response: gain, noise everywhere, monochrome cameras") {
    SynthConfig config = base;
    config.effects.camera_response = true;
    config.effects.monochrome_every = 2;
    const SynthScene scene = make_synth_scene(config);
    const SynthView colour = render_synth_frame(scene, frame, 0);
    const SynthView mono = render_synth_frame(scene, frame, 1);
    std::vector<cv::Mat> c;
    cv::split(mono.bgr, c);
    CHECK(cv::countNonZero(c[0] != c[1]) == 0);
    CHECK(cv::countNonZero(c[1] != c[2]) == 0);
    cv::split(colour.bgr, c);
    CHECK(cv::countNonZero(c[0] != c[2]) > 1000);
    cv::Scalar mean, std;
    cv::meanStdDev(colour.bgr, mean, std, colour.samples == 0);
    CHECK(mean[1] < 12);
    CHECK(std[1] > 0.8);
    // The same geometry: where the hand is does not change.
    CHECK(cv::countNonZero(colour.coverage != reference.coverage) == 0);
  }
}

TEST_CASE("synth effects: gestures move fingers independently and hold out unseen ones") {
  const Rig rig = load_rig_source("builtin");
  std::vector<std::string> names;
  const int frames = 100, held_out = 50;
  const std::vector<SynthPose> poses = make_gesture_poses(rig, frames, held_out, 3, &names);
  std::set<std::string> unseen;
  for (const Gesture& g : gesture_vocabulary())
    if (g.held_out_only) unseen.insert(g.name);
  int tail_unseen = 0;
  for (int k = 0; k < frames; ++k) {
    if (k < frames - held_out) REQUIRE(unseen.count(names[k]) == 0);
    else tail_unseen += unseen.count(names[k]) > 0;
  }
  CHECK(tail_unseen >= 10);
  // Independence: the range of motion's twelve finger flexions are phase-shifted copies of one
  // wave (two principal components explain them); the gestures' need many more.
  auto top_two_share = [](const std::vector<SynthPose>& p) {
    torch::Tensor x = torch::empty({static_cast<int64_t>(p.size()), 12}, torch::kFloat64);
    for (size_t k = 0; k < p.size(); ++k)
      for (int f = 1; f < 5; ++f)
        for (int j = 0; j < 3; ++j) x[k][(f - 1) * 3 + j] = p[k].articulation.flex[f][j];
    x = x - x.mean(0, true);
    const torch::Tensor s2 = std::get<1>(torch::svd(x)).pow(2);
    return (s2[0] + s2[1]).item<double>() / s2.sum().item<double>();
  };
  const std::vector<SynthPose> rom = make_rom_poses(rig, frames, 3);
  CHECK(top_two_share(rom) > 0.98);
  CHECK(top_two_share(poses) < 0.85);
  // Physically possible: below 1.2 rad per 5 fps frame (6 rad/s; fast finger motions reach 15).
  for (int k = 1; k < frames; ++k)
    for (int f = 0; f < 5; ++f)
      for (int j = 0; j < 3; ++j)
        CHECK(std::fabs(poses[k].articulation.flex[f][j] - poses[k - 1].articulation.flex[f][j]) <
              1.2);
}

TEST_CASE("synth effects: the realistic capture is the same on any thread count") {
  const std::string one = data_test::fresh_dir("synth_real_1"),
                    two = data_test::fresh_dir("synth_real_2");
  const int saved = omp_get_max_threads();
  handscs::set_threads(1);  // LibTorch and OpenMP, as handscs-synth --threads
  generate_synth_capture(synth_preset("real_tiny"), one);
  handscs::set_threads(2);  // LibTorch and OpenMP, as handscs-synth --threads
  generate_synth_capture(synth_preset("real_tiny"), two);
  handscs::set_threads(saved);  // LibTorch and OpenMP, as handscs-synth --threads
  int files = 0, regions = 0;
  for (const auto& entry : fs::recursive_directory_iterator(one)) {
    if (!entry.is_regular_file()) continue;
    const fs::path other = fs::path(two) / fs::relative(entry.path(), one);
    REQUIRE(fs::exists(other));
    CHECK(read_file(entry.path().string()) == read_file(other.string()));
    ++files;
    regions += entry.path().extension() == ".png";
  }
  CHECK(regions == 4 * 12);
  CHECK(files == 2 * 4 * 12 + 4 + 3);  // images, masks, annotations, legend, synth.json, frames.csv
  CHECK(fs::exists(fs::path(one) / "regions" / "regions.json"));

  // frames.csv: one row per pose; its held-out rows are the poses the reader holds out; a gesture is
  // "in training" exactly when a training row moves to it, and the vocabulary's held-out-only
  // gestures never are.
  const SynthConfig preset = synth_preset("real_tiny");
  const CsvTable frames = read_csv((fs::path(one) / "frames.csv").string());
  CHECK(frames.header ==
        std::vector<std::string>{"seq_name", "frame_idx", "held_out", "gesture", "gesture_in_training"});
  const auto& rows = frames.rows;
  REQUIRE(rows.size() == static_cast<size_t>(preset.num_frames));
  std::set<std::string> trained, unseen;
  std::set<int64_t> held_out_frames;
  for (const auto& row : rows) {
    if (row[2] == "0") trained.insert(row[3]);
    else held_out_frames.insert(std::stoll(row[1]));
  }
  for (const Gesture& g : gesture_vocabulary())
    if (g.held_out_only) unseen.insert(g.name);
  for (size_t k = 0; k < rows.size(); ++k) {
    CHECK(std::stoll(rows[k][1]) == static_cast<int64_t>(k) * preset.frame_step);
    CHECK(rows[k][4] == (trained.count(rows[k][3]) ? "1" : "0"));
    if (rows[k][2] == "0") CHECK(unseen.count(rows[k][3]) == 0);
  }
  CHECK(held_out_frames.size() == static_cast<size_t>(preset.held_out_frames));
  CaptureConfig config;
  config.root = one;
  config.held_out_poses = preset.held_out_frames;
  config.cache.prefetch_threads = 0;
  std::set<int64_t> test_frames;
  for (const auto& f : Capture::open(config).test()) test_frames.insert(f.frame_idx);
  CHECK(test_frames == held_out_frames);
}
