// Evaluation with per-camera colour transforms (train.camera_color): a training camera's images are
// rendered through its transform, a camera the avatar never saw (the novel-view split) with the
// avatar's own colours, and summary.json and table.md say which; a checkpoint without transforms
// evaluates as before.
#include "catch_torch.h"

#include <algorithm>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "core/atomic_file.h"
#include "core/threads.h"
#include "infer/evaluate.h"
#include "metrics/comparison_panel.h"
#include "run/checkpoint.h"
#include "train/tiny_capture.h"
#include "train/trainer.h"

using handscs_test::fresh_dir;
using handscs_test::tiny_run_config;

namespace {

// Evaluates `checkpoint` on `split` of `config`'s capture with side-by-side PNGs; returns the
// summary.json.
nlohmann::json evaluate_split(const handscs::RunConfig& config, const std::string& checkpoint,
                              const std::string& split, const std::string& out) {
  handscs::ModelEvalOptions options;
  options.checkpoint = checkpoint;
  options.out_dir = out;
  options.split = split;
  options.side_by_side = true;
  handscs::evaluate_avatar(config, options);
  return nlohmann::json::parse(handscs::read_file(out + "/summary.json"));
}

// The prediction third of a side-by-side PNG, as float levels.
// The render column of a side-by-side panel, below its header (metrics/comparison_panel.h).
cv::Mat prediction_of(const std::string& png) {
  const cv::Mat image = cv::imread(png, cv::IMREAD_COLOR);
  const int width = image.cols / 3;
  const int top = handscs::comparison_panel_header_height(width);
  cv::Mat out;
  image(cv::Rect(0, top, width, image.rows - top)).convertTo(out, CV_32FC3);
  return out;
}

}  // namespace

TEST_CASE("camera colour eval: a training camera's transform applies, an unseen camera's identity") {
  handscs::set_threads(2);
  // Novel view: three cameras train, the fourth is only tested.
  auto config = tiny_run_config();
  std::vector<std::string> ids;
  for (const auto& entry : std::filesystem::recursive_directory_iterator(config.data.root + "/images"))
    if (entry.is_directory() && entry.path().filename().string().rfind("cam", 0) == 0)
      ids.push_back(entry.path().filename().string().substr(3));
  std::sort(ids.begin(), ids.end());
  REQUIRE(ids.size() == 4);
  config.data.split_rule = handscs::CaptureConfig::SplitRule::novel_view;
  config.data.train_cameras = {ids[0], ids[1], ids[2]};
  config.data.test_cameras = {ids[3]};
  config.train.iterations = 20;
  config.train.checkpoint_every = 20;
  config.train.densify.enabled = false;
  config.train.camera_color = handscs::TrainConfig::CameraColor::gain;
  const auto run = fresh_dir("color_eval_run");
  {
    handscs::Trainer trainer(config, run);
    while (trainer.iteration() < config.train.iterations) trainer.step();
    trainer.save_checkpoint();
  }
  const std::string trained = handscs::latest_checkpoint(run);
  // The same avatar with known transforms: the first camera halves every channel, the others are
  // the identity; and with none at all (an older checkpoint).
  auto checkpoint = handscs::load_checkpoint(trained);
  const auto stored_ids = checkpoint.meta.at("camera_color").at("cameras").get<std::vector<std::string>>();
  CHECK(stored_ids == std::vector<std::string>{ids[0], ids[1], ids[2]});
  auto params = torch::zeros({3, 6});
  params[0].slice(0, 0, 3).fill_(-0.5);
  checkpoint.tensors["camera_color/params"] = params;
  const std::string halved = run + "/halved.ckpt";
  handscs::save_checkpoint(halved, checkpoint);
  checkpoint.tensors.erase("camera_color/params");
  checkpoint.meta.erase("camera_color");
  const std::string plain = run + "/plain.ckpt";
  handscs::save_checkpoint(plain, checkpoint);

  // The unseen camera: its images get the avatar's own colours, the same scores as without
  // transforms.
  const auto unseen = evaluate_split(config, halved, "test", run + "/eval_unseen");
  const auto unseen_plain = evaluate_split(config, plain, "test", run + "/eval_unseen_plain");
  CHECK(unseen.at("camera_color").at("mode") == "gain");
  CHECK(unseen.at("camera_color").at("transformed_images") == 0);
  CHECK(unseen.at("camera_color").at("identity_cameras") == std::vector<std::string>{ids[3]});
  CHECK(unseen.at("summary").at("psnr").get<double>() ==
        unseen_plain.at("summary").at("psnr").get<double>());
  CHECK(unseen_plain.at("camera_color").at("mode") == "off");
  CHECK(handscs::read_file(run + "/eval_unseen/table.md").find("cameras it never saw") != std::string::npos);

  // The training cameras: every image through its camera's transform; the first camera's
  // prediction is half the plain one (within the PNGs' rounding), the others' equal it.
  const auto seen = evaluate_split(config, halved, "train", run + "/eval_seen");
  evaluate_split(config, plain, "train", run + "/eval_seen_plain");
  CHECK(seen.at("camera_color").at("identity_images") == 0);
  CHECK(seen.at("camera_color").at("transformed_cameras").size() == 3);
  int checked_halved = 0, checked_same = 0;
  for (const auto& entry : std::filesystem::directory_iterator(run + "/eval_seen/side_by_side")) {
    const std::string name = entry.path().filename().string();
    const cv::Mat with = prediction_of(entry.path().string());
    const cv::Mat without = prediction_of(run + "/eval_seen_plain/side_by_side/" + name);
    const bool first_camera = name.find("cam" + ids[0]) != std::string::npos;
    INFO(name);
    double worst = 0, brightest = 0;
    // Where the plain render saturates (clamped at 1) half of it is not half the clamped value.
    cv::Mat difference = cv::abs(with - (first_camera ? 0.5 : 1.0) * without);
    difference.setTo(cv::Scalar::all(0), without > 254);
    cv::minMaxLoc(difference.reshape(1), nullptr, &worst);
    cv::minMaxLoc(without.reshape(1), nullptr, &brightest);
    REQUIRE(brightest > 50);  // the hand is in the picture
    CHECK(worst <= 1.0);      // 8-bit rounding of both images: <= 1 level
    ++(first_camera ? checked_halved : checked_same);
  }
  CHECK(checked_halved > 0);
  CHECK(checked_same > 0);
}
