// Driving a trained avatar from keypoints: a keypoint file given to handscs-render as POSES is
// fitted with the avatar's rig and renders as the pose whose joints it holds.
#include "catch_torch.h"

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "core/threads.h"
#include "hand/keypoint_order.h"
#include "hand/lbs_one_pose.h"
#include "infer/avatar_render.h"
#include "infer/pose_source.h"
#include "train/tiny_capture.h"
#include "train/trainer.h"

using handscs_test::fresh_dir;

TEST_CASE("keypoint poses: a keypoint file renders as the pose its joints came from") {
  handscs::set_threads(2);
  handscs::RunConfig config = handscs_test::tiny_run_config();
  config.train.iterations = 20;
  const std::string run = fresh_dir("keypoint_poses_run");
  handscs::Trainer trainer(config, run);
  while (trainer.iteration() < config.train.iterations) REQUIRE_FALSE(trainer.step().skipped);
  trainer.save_checkpoint();
  const handscs::Rig& rig = trainer.avatar().rig();

  // A pose without twist (the fit holds twist at zero): the rig's mean pose bent 30% further,
  // relative to hands_mean as the run's poses are, turned and moved in front of the orbit.
  std::array<double, 48> pose{};
  const auto mean = rig.hands_mean.to(torch::kFloat64).contiguous();
  for (int i = 3; i < 48; ++i) pose[i] = 0.3 * mean.data_ptr<double>()[i - 3];
  pose[1] = 0.4;
  const std::array<double, 3> trans{0.01, -0.02, 0.03};
  const auto f64 = torch::kFloat64;
  const auto joints = handscs::lbs_one_pose(rig, torch::tensor(std::vector<double>(pose.begin(), pose.end()), f64),
                                            torch::zeros({10}, f64),
                                            torch::tensor(std::vector<double>(trans.begin(), trans.end()), f64),
                                            handscs::LbsOptions{config.model.flat_hand_mean})
                          .joints.reshape({21, 3}).contiguous();
  const auto order = handscs::mano21_from_order(handscs::KeypointOrder::mediapipe);
  nlohmann::json rows = nlohmann::json::array();
  for (int i = 0; i < 21; ++i) rows.push_back(nullptr);
  for (int j = 0; j < 21; ++j)
    rows[order[j]] = {1e3 * joints[j][0].item<double>(), 1e3 * joints[j][1].item<double>(),
                      1e3 * joints[j][2].item<double>()};
  const std::string keypoints = run + "/keypoints.json";
  std::ofstream(keypoints) << nlohmann::json{{"format", "handscs-keypoints"}, {"order", "mediapipe"},
                                             {"units", "mm"},
                                             {"frames", {{{"name", "k0"}, {"right", rows}}}}}
                                  .dump();
  const std::string poses = run + "/poses.json";
  std::ofstream(poses) << nlohmann::json{{"poses", {{{"pose", pose}, {"trans", trans}}}}}.dump();

  // Without an avatar there is no rig to fit.
  CHECK_THROWS_WITH(handscs::read_pose_source(keypoints), Catch::Contains("a keypoint file, which needs an avatar's rig"));

  handscs::AvatarRenderOptions options;
  options.checkpoint = run;
  options.orbit = 2;
  options.poses = poses;
  options.out_dir = run + "/from_poses";
  REQUIRE(handscs::render_avatar(options).frames == 2);
  options.poses = keypoints;
  options.out_dir = run + "/from_keypoints";
  REQUIRE(handscs::render_avatar(options).frames == 2);
  for (const char* frame : {"frame_0000.png", "frame_0001.png"}) {
    const cv::Mat a = cv::imread(run + "/from_poses/" + frame), b = cv::imread(run + "/from_keypoints/" + frame);
    REQUIRE(a.size() == b.size());
    cv::Mat diff;
    cv::absdiff(a, b, diff);
    const double mean_levels = cv::mean(diff)[0] + cv::mean(diff)[1] + cv::mean(diff)[2];
    // The fit recovers the joints to well under a millimetre; what differs is the shape it fits
    // (joints see only some modes) and rounding: a few pixels along the hand's outline.
    INFO(frame << ": mean |difference| " << mean_levels << " levels (sum over channels)");
    CHECK(mean_levels < 1.0);
  }
}
