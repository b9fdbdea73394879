// Two hands (data.hand both): the capture's masks cover both meshes and keep a frame that lacks
// one hand; the trainer gives each hand its own avatar, composites both in one rasteriser call,
// leaves a hand no frame has untouched, and checkpoints and resumes both exactly.
#include "catch_torch.h"

#include <algorithm>
#include <filesystem>
#include <opencv2/core.hpp>

#include "core/float_vector.h"
#include "core/threads.h"
#include "data/capture.h"
#include "data/mesh_mask.h"
#include "hand/lbs.h"
#include "run/checkpoint.h"
#include "run/run_config.h"
#include "checkpoint_compare.h"
#include "tiny_capture.h"
#include "two_hand_capture.h"
#include "train/trainer.h"

using handscs::CaptureConfig;
using handscs::Handedness;
using handscs_test::fresh_dir;

namespace {

constexpr int64_t kFrameWithoutLeft = 6;  // tiny's second frame (frame_step 6)

handscs::RunConfig two_hand_config(const std::string& root) {
  handscs::RunConfig config = handscs_test::tiny_run_config();
  config.data.root = root;
  config.data.hand = CaptureConfig::Hands::both;
  config.train.iterations = 6;
  config.train.checkpoint_every = 3;
  config.train.log_every = 1;
  return config;
}

// The mask of one hand's mesh, posed here from the frame's parameters (not the capture's vertices).
cv::Mat hand_mask(const CaptureConfig& config, const handscs::FrameInfo& frame, Handedness side) {
  const handscs::Rig rig = handscs::capture_rig(config, side);
  const handscs::HandParams& p = *frame.hand(side);
  handscs::LbsOptions options;
  options.flat_hand_mean = config.flat_hand_mean;
  torch::NoGradGuard no_grad;
  const auto as_row = [](const auto& values) {
    return handscs::float_vector(values).to(torch::kFloat64).unsqueeze(0);
  };
  const torch::Tensor vertices =
      handscs::lbs(rig, as_row(p.pose), as_row(p.shape), as_row(p.trans), options)
          .vertices[0].to(torch::kFloat32).contiguous();
  const torch::Tensor faces = rig.faces.to(torch::kInt64).contiguous();
  return handscs::mesh_mask(vertices.data_ptr<float>(), vertices.size(0), faces.data_ptr<int64_t>(),
                            faces.size(0), frame.camera);
}

}  // namespace

TEST_CASE("two hands: a frame's mask is both meshes, and a frame without one hand stays") {
  const std::string root = handscs_test::make_two_hand_capture(
      fresh_dir("two_hands_masks"), {0.06, {kFrameWithoutLeft}, false});
  CaptureConfig config;
  config.root = root;
  config.held_out_poses = 3;
  config.mask_refine.enabled = false;  // the meshes' own masks
  config.hand = CaptureConfig::Hands::right;
  config.include_interacting = true;  // the fixture's frames show both hands
  const handscs::Capture right = handscs::Capture::open(config);
  config.hand = CaptureConfig::Hands::both;
  handscs::Capture both = handscs::Capture::open(config);
  // Every frame has a right hand: both hands keep every image the right hand has.
  REQUIRE(both.frames().size() == right.frames().size());

  const int64_t hand_vertices = handscs::capture_rig(config, Handedness::right).num_vertices();
  int64_t two = 0, one = 0, left_pixels = 0;
  for (const handscs::FrameInfo& frame : both.frames()) {
    REQUIRE(frame.hand(Handedness::right) != nullptr);
    const bool has_left = frame.frame_idx != kFrameWithoutLeft;
    REQUIRE((frame.hand(Handedness::left) != nullptr) == has_left);
    const int64_t vertices = static_cast<int64_t>(both.posed_vertices(frame.pose_index).size() / 3);
    CHECK(vertices == (has_left ? 2 : 1) * hand_vertices);
    if (frame.camera_id != both.frames().front().camera_id) continue;  // one camera is enough
    cv::Mat expected = hand_mask(config, frame, Handedness::right);
    if (has_left) {
      const cv::Mat left = hand_mask(config, frame, Handedness::left);
      left_pixels += cv::countNonZero(left & ~expected);
      expected |= left;
    }
    const cv::Mat mask = both.compute_mask(frame, both.decode_image(frame)) > 0;
    CHECK(cv::countNonZero(mask != (expected > 0)) == 0);
    (has_left ? two : one) += 1;
  }
  CHECK(two > 0);
  CHECK(one > 0);
  CHECK(left_pixels > 0);  // the left hand adds pixels of its own: the union is not vacuous
}

TEST_CASE("two hands: one rasteriser call composites both: alpha = 1 - (1 - a_right)(1 - a_left)") {
  handscs::set_threads(2);
  const std::string root = handscs_test::make_two_hand_capture(fresh_dir("two_hands_composite"));
  handscs::Trainer trainer(two_hand_config(root), fresh_dir("two_hands_composite_run"));
  REQUIRE(trainer.hand_count() == 2);
  const handscs::FrameInfo& frame = trainer.capture().train().front();
  c10::InferenceMode guard;
  std::vector<handscs::AvatarState> states;
  for (const Handedness side : {Handedness::right, Handedness::left}) {
    const handscs::FrameInfo own = handscs::frame_of_hand(frame, side);
    states.push_back(trainer.avatar(side).pose(handscs::float_vector(own.pose),
                                               handscs::float_vector(own.shape),
                                               handscs::float_vector(own.trans)));
  }
  const handscs::RasterSettings settings;
  const auto right = handscs::render_posed(states[0].posed, frame.camera, settings);
  const auto left = handscs::render_posed(states[1].posed, frame.camera, settings);
  const auto joined =
      handscs::render_posed(handscs::join_posed({&states[0].posed, &states[1].posed}), frame.camera, settings);
  // Transmittance multiplies over every Gaussian a pixel meets, in any order (up to the early stop
  // at T < 1e-4).
  const auto expected_alpha = 1 - (1 - right.alpha) * (1 - left.alpha);
  CHECK((joined.alpha - expected_alpha).abs().max().item<double>() < 2e-3);
  // Where one hand alone covers a pixel, the picture is that hand's.
  const auto only_right = (right.alpha > 0) & (left.alpha == 0);
  const auto only_left = (left.alpha > 0) & (right.alpha == 0);
  REQUIRE(only_right.sum().item<int64_t>() > 0);
  REQUIRE(only_left.sum().item<int64_t>() > 0);
  CHECK((joined.rgb - right.rgb).abs().amax(2).masked_select(only_right).max().item<double>() < 1e-5);
  CHECK((joined.rgb - left.rgb).abs().amax(2).masked_select(only_left).max().item<double>() < 1e-5);
  // Both overlap somewhere: the hands occlude each other in this view.
  CHECK(((right.alpha > 0.5) & (left.alpha > 0.5)).sum().item<int64_t>() > 0);
}

TEST_CASE("two hands: a hand no frame has keeps its initial avatar while the other trains") {
  handscs::set_threads(2);
  const std::string root =
      handscs_test::make_two_hand_capture(fresh_dir("two_hands_no_left"), {0.06, {}, true});
  handscs::Trainer trainer(two_hand_config(root), fresh_dir("two_hands_no_left_run"));
  const torch::Tensor right_before = trainer.avatar(Handedness::right).gaussians().means.detach().clone();
  const torch::Tensor left_before = trainer.avatar(Handedness::left).gaussians().means.detach().clone();
  for (int k = 0; k < 3; ++k) REQUIRE_FALSE(trainer.step().skipped);
  CHECK_FALSE(torch::equal(trainer.avatar(Handedness::right).gaussians().means, right_before));
  CHECK(torch::equal(trainer.avatar(Handedness::left).gaussians().means, left_before));
}

TEST_CASE("two hands: both train, and a checkpoint holds both and resumes exactly") {
  handscs::set_threads(2);
  const std::string root = handscs_test::make_two_hand_capture(fresh_dir("two_hands_resume"));
  const handscs::RunConfig config = two_hand_config(root);
  const std::string full = fresh_dir("two_hands_resume_full");
  std::string last;
  {
    handscs::Trainer trainer(config, full);
    const torch::Tensor left_before = trainer.avatar(Handedness::left).gaussians().means.detach().clone();
    const auto summary = trainer.run();
    REQUIRE(summary.iterations == 6);
    CHECK(summary.skipped_steps == 0);
    CHECK(summary.gaussians == trainer.avatar(Handedness::right).gaussians().size() +
                                   trainer.avatar(Handedness::left).gaussians().size());
    CHECK_FALSE(torch::equal(trainer.avatar(Handedness::left).gaussians().means, left_before));
    last = summary.checkpoint;
  }
  const handscs::Checkpoint done = handscs::load_checkpoint(last);
  CHECK(done.tensors.count("gaussians/means") == 1);
  CHECK(done.tensors.count("left/gaussians/means") == 1);
  CHECK(done.tensors.count("left/adam/means/0/m") == 1);
  CHECK(done.meta.contains("left"));

  // The same run stopped after step 3 and resumed from its checkpoint there.
  const std::string resumed = fresh_dir("two_hands_resume_again");
  std::filesystem::copy(full, resumed, std::filesystem::copy_options::recursive);
  std::filesystem::remove(resumed + "/checkpoints/" + std::filesystem::path(last).filename().string());
  handscs::Trainer again(config, resumed);
  REQUIRE(again.resume());
  REQUIRE(again.iteration() == 3);
  const auto summary = again.run();
  const handscs::Checkpoint other = handscs::load_checkpoint(summary.checkpoint);
  const auto difference = handscs_test::compare_checkpoints(done, other, 1.0);
  CHECK(difference.mismatch.empty());
  CHECK(difference.worst == 0.0);
  INFO(difference.worst_name);
}

TEST_CASE("two hands: shared decoders are one set, stepped once per step, and stay shared on resume") {
  handscs::set_threads(2);
  const std::string root = handscs_test::make_two_hand_capture(fresh_dir("two_hands_shared"));
  handscs::RunConfig config = two_hand_config(root);
  config.model.shared_decoders = true;
  const std::string full = fresh_dir("two_hands_shared_full");
  std::string last;
  {
    handscs::Trainer trainer(config, full);
    auto& right = trainer.avatar(Handedness::right);
    auto& left = trainer.avatar(Handedness::left);
    REQUIRE(right.decoders().get() == left.decoders().get());
    // The gates: the first step's gradient reaches them alone (they start at 0, which stops it
    // reaching the layers behind them).
    auto gates = [&] {
      std::vector<torch::Tensor> out;
      for (const auto& item : right.decoders()->named_parameters())
        if (item.key().find("gate") != std::string::npos) out.push_back(item.value().detach().clone());
      return out;
    };
    const std::vector<torch::Tensor> before = gates();
    REQUIRE(before.size() == 3);
    REQUIRE_FALSE(trainer.step().skipped);
    // Adam's first step moves a parameter by lr * g / (|g| + eps) <= lr: once, with the gradient
    // of both hands' losses.
    const double lr = config.train.lr.gates;
    double largest = 0;
    const std::vector<torch::Tensor> after = gates();
    for (size_t k = 0; k < after.size(); ++k)
      largest = std::max(largest, (after[k] - before[k]).abs().max().item<double>());
    CHECK(largest <= lr * (1 + 1e-5));
    CHECK(largest > 0.9 * lr);
    last = trainer.run().checkpoint;
  }
  // The checkpoint's left section holds the same decoders (a copy, so it reads as any two-hand one).
  const handscs::Checkpoint done = handscs::load_checkpoint(last);
  int64_t compared = 0;
  for (const auto& [name, tensor] : done.tensors)
    if (name.rfind("network/decoders.", 0) == 0) {
      REQUIRE(done.tensors.count("left/" + name) == 1);
      CHECK(torch::equal(tensor, done.tensors.at("left/" + name)));
      ++compared;
    }
  CHECK(compared > 0);
  // Their optimiser state is the first hand's alone.
  CHECK(done.tensors.count("adam/decoders/0/m") == 1);
  CHECK(done.tensors.count("adam/gates/0/m") == 1);
  for (const auto& [name, tensor] : done.tensors) {
    CHECK(name.rfind("left/adam/decoders/", 0) != 0);
    CHECK(name.rfind("left/adam/gates/", 0) != 0);
  }

  // Resumed from step 3: still one set, and the run ends as the uninterrupted one.
  const std::string resumed = fresh_dir("two_hands_shared_again");
  std::filesystem::copy(full, resumed, std::filesystem::copy_options::recursive);
  std::filesystem::remove(resumed + "/checkpoints/" + std::filesystem::path(last).filename().string());
  handscs::Trainer again(config, resumed);
  REQUIRE(again.resume());
  REQUIRE(again.iteration() == 3);
  CHECK(again.avatar(Handedness::right).decoders().get() == again.avatar(Handedness::left).decoders().get());
  const auto difference = handscs_test::compare_checkpoints(done, handscs::load_checkpoint(again.run().checkpoint), 1.0);
  CHECK(difference.mismatch.empty());
  CHECK(difference.worst == 0.0);
  INFO(difference.worst_name);

  // One hand has nothing to share with.
  config.data.hand = CaptureConfig::Hands::right;
  CHECK(handscs_test::error_of([&] { handscs::validate_run_config(config, "config"); }) ==
        "config: model.shared_decoders shares the decoders between two hands; it needs data.hand both");
}
