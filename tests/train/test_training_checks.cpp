// Checks of a training run against its capture: a train.resolution_scale that shrinks images or
// crops below the SSIM window is an error naming the key before any step (and the scale it
// suggests is enough), and a run whose first hand masks are all empty fails instead of "training"
// on nothing.
#include "catch_torch.h"

#include <filesystem>
#include <functional>

#include <opencv2/imgcodecs.hpp>

#include "core/error.h"
#include "metrics/ssim.h"
#include "test_support.h"
#include "tiny_capture.h"
#include "train/losses.h"
#include "train/trainer.h"
#include "train/training_checks.h"

using handscs_test::error_of;
using handscs_test::fresh_dir;
using handscs_test::tiny_run_config;

TEST_CASE("training checks: the image losses' smallest side follows the losses that are on") {
  handscs::LossWeights weights;
  CHECK(handscs::min_loss_image_side(weights, nullptr) == handscs::kSsimWindow);
  weights.ssim = 0;
  CHECK(handscs::min_loss_image_side(weights, nullptr) == 1);
}

TEST_CASE("training checks: LPIPS on a scaled crop needs the crop larger by that scale") {
  handscs::LpipsConfig config;
  config.weights = handscs_test::kLpipsAlexWeights;
  const handscs::Lpips lpips(config);
  const int64_t backbone = lpips.min_image_side();
  handscs::LossWeights weights;
  weights.ssim = 0;
  CHECK(handscs::min_loss_image_side(weights, &lpips) == backbone);
  for (const double scale : {0.5, 0.3, 0.25}) {
    weights.lpips_scale = scale;
    const int64_t side = handscs::min_loss_image_side(weights, &lpips);
    // The smallest side whose scaled image the backbone still accepts.
    CHECK(handscs::scaled_side(side, scale) >= backbone);
    CHECK(handscs::scaled_side(side - 1, scale) < backbone);
    // The backbone itself takes the scaled crop of that side and refuses that of one pixel less.
    const auto crop = [&](int64_t s) {
      const int64_t scaled = handscs::scaled_side(s, scale);
      return torch::rand({1, 3, scaled, scaled});
    };
    CHECK_NOTHROW(lpips.distance(crop(side), crop(side)));
    CHECK_THROWS(lpips.distance(crop(side - 1), crop(side - 1)));
  }
}

TEST_CASE("training checks: a resolution_scale below the SSIM window is refused before step 1") {
  auto config = tiny_run_config();
  config.train.resolution_scale = 0.05;
  const std::string dir = fresh_dir("scale_too_small");
  const std::string error = error_of([&] { handscs::Trainer trainer(config, dir); });
  INFO(error);
  // tiny's images are 167x256: 0.05 gives 8x13; 11 / 167 = 0.0659 -> 0.066.
  CHECK(error.rfind("train.resolution_scale: 0.05 scales the 167x256 images (" +
                        handscs_test::tiny_capture_dir() + "/images/test/Capture0/",
                    0) == 0);
  CHECK(error.find(") to 8x13, smaller than the 11x11 the image losses need (SSIM window, LPIPS "
                   "backbone after train.loss.lpips_scale); use at least 0.066 (crops around the "
                   "hand need more), or set train.loss.ssim and train.loss.lpips to 0") !=
        std::string::npos);
  CHECK_FALSE(std::filesystem::exists(dir + "/config.json"));

  // The suggested scale passes the full-image check (167 * 0.066 rounds to 11).
  handscs::Trainer probe(tiny_run_config(), fresh_dir("scale_probe"));
  CHECK_NOTHROW(handscs::check_training_image_sizes(probe.capture().train(), 0.066, 11));
  CHECK_THROWS(handscs::check_training_image_sizes(probe.capture().train(), 0.059, 11));
  // Without SSIM and LPIPS any scale is allowed.
  CHECK_NOTHROW(handscs::check_training_image_sizes(probe.capture().train(), 0.05, 1));
}

TEST_CASE("training checks: a crop scaled below the window names the image and a scale that fits") {
  handscs::FrameInfo frame;
  frame.image_path = "/data/cam1/image7.jpg";
  CHECK(handscs::scaled_crop_problem(frame, 11, 11, 0.1, 11).empty());
  // A 130x90 crop at 0.1 is 13x9; 11 / 90 = 0.1222 -> 0.123.
  CHECK(handscs::scaled_crop_problem(frame, 13, 9, 0.1, 11) ==
        "train.resolution_scale: 0.1 scales the crop around the hand in /data/cam1/image7.jpg to "
        "13x9, smaller than the 11x11 the image losses need (SSIM window, LPIPS backbone after train.loss.lpips_scale); use at "
        "least 0.123, or set train.loss.ssim and train.loss.lpips to 0");
}

TEST_CASE("training checks: empty masks in the first steps fail the run, later ones are counted") {
  handscs::FrameInfo frame;
  frame.image_path = "/data/cam1/image7.jpg";
  handscs::EmptyMaskWatch all_empty(3);
  all_empty.record(frame, true);
  all_empty.record(frame, true);
  CHECK(error_of([&] { all_empty.record(frame, true); }) ==
        "the hand masks of the first 3 training images are all empty (the last: "
        "/data/cam1/image7.jpg): nothing to learn from. The posed MANO hand covers no pixel of these "
        "views: check the MANO annotation (shape, trans), data.hand, data.rig and the cameras");

  handscs::EmptyMaskWatch some_hand(3);
  some_hand.record(frame, false);
  for (int k = 0; k < 10; ++k) CHECK_NOTHROW(some_hand.record(frame, true));
  CHECK(some_hand.empty_count() == 10);
}

TEST_CASE("training checks: all-empty supplied masks are named as the mask files, not the hand") {
  handscs::FrameInfo frame;
  frame.image_path = "/data/images/cam1/7.jpg";
  frame.mask_path = "/data/masks/cam1/7.png";
  handscs::EmptyMaskWatch all_empty(2);
  all_empty.record(frame, true);
  CHECK(error_of([&] { all_empty.record(frame, true); }) ==
        "the hand masks of the first 2 training images are all empty (the last: mask "
        "/data/masks/cam1/7.png of /data/images/cam1/7.jpg): nothing to learn from. The supplied "
        "masks hold no hand pixel: check the mask files (non-zero = hand)");
}

TEST_CASE("training checks: a capture whose masks are all empty stops at step 16 with an error") {
  // Plant an all-zero mask for every frame in the run's mask cache: the loader reads them as
  // the masks of the capture (as a hand posed outside every view would give).
  auto config = tiny_run_config();
  handscs::Trainer trainer(config, fresh_dir("empty_masks"));
  const std::string folder = trainer.capture().mask_cache_folder();
  REQUIRE(!folder.empty());
  for (const auto& f : trainer.capture().frames()) {
    const auto file = std::filesystem::path(folder) / std::filesystem::path(f.file_name).replace_extension(".png");
    std::filesystem::create_directories(file.parent_path());
    REQUIRE(cv::imwrite(file.string(), cv::Mat::zeros(f.camera.height, f.camera.width, CV_8UC1)));
  }
  std::string error = "(no error)";
  int steps = 0;
  while (error == "(no error)" && steps < 20) {
    error = error_of([&] { trainer.step(); });
    ++steps;
  }
  INFO(error);
  CHECK(steps == 16);
  CHECK(error.rfind("the hand masks of the first 16 training images are all empty (the last: ", 0) == 0);
}

TEST_CASE("training checks: a batch larger than the training views is named with what a step costs") {
  CHECK(handscs::batch_size_warning(36, 1, 36).empty());
  CHECK(handscs::batch_size_warning(8, 2, 36).empty());
  CHECK(handscs::batch_size_warning(4096, 1, 36) ==
        "train.batch_size: 4096 views a step but the capture has 36 training views: each view is "
        "rendered ~113.8 times a step, and a step costs 4096 renders");
  CHECK(handscs::batch_size_warning(20, 2, 36) ==
        "train.batch_size: 40 views a step (2 processes) but the capture has 36 training views: "
        "each view is rendered ~1.1 times a step, and a step costs 40 renders");
}

TEST_CASE("training checks: data.hand both names a hand that no training frame has") {
  std::vector<handscs::FrameInfo> train(3);
  for (auto& frame : train) frame.hands[0] = handscs::HandParams{};  // right only
  CHECK(handscs::missing_hand_warning(train) ==
        "data.hand both: none of the 3 training frames has the left hand (its annotations are absent "
        "or null), so its avatar would keep its initial state; data.hand=right trains the right hand "
        "alone");
  train[1].hands[1] = handscs::HandParams{};  // one frame with the left hand is enough
  CHECK(handscs::missing_hand_warning(train).empty());
  for (auto& frame : train) frame.hands[0].reset();  // left only
  CHECK(handscs::missing_hand_warning(train).find("has the right hand") != std::string::npos);
}
