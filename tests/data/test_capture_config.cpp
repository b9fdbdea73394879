// CaptureConfig reads from JSON through the shared config visitor (defaults, nested sections,
// key-path errors).
#include "core/config.h"
#include "data/capture_config.h"

// Catch last: LibTorch pulls in glog, whose CHECK macro would otherwise replace Catch's.
#include <catch2/catch.hpp>

using namespace handscs;

TEST_CASE("capture config: JSON in and out, errors name the key") {
  CaptureConfig config;
  const json defaults = config_to_json(config);
  CHECK(defaults["split_rule"] == "novel_pose");
  CHECK(defaults["held_out_poses"] == 50);
  CHECK(defaults["mask_refine"]["low"] == 10);
  CHECK(defaults["mask_refine"]["high"] == 200);
  CHECK(defaults["cache"]["budget_mb"] == 1024);

  const json file = {{"root", "/data/InterHand2.6M"},
                     {"capture", 0},
                     {"sequences", {"ROM03_RT_No_Occlusion"}},
                     {"test_cameras", {"400262"}},
                     {"split_rule", "novel_view"},
                     {"mask_refine", {{"largest_component", false}}},
                     {"cache", {{"budget_mb", 512}}}};
  config_from_json(file, "capture.json", config);
  CHECK(config.root == "/data/InterHand2.6M");
  CHECK(config.sequences == std::vector<std::string>{"ROM03_RT_No_Occlusion"});
  CHECK(config.split_rule == CaptureConfig::SplitRule::novel_view);
  CHECK_FALSE(config.mask_refine.largest_component);
  CHECK(config.mask_refine.low == 10);
  CHECK(config.cache.budget_mb == 512);

  auto error = [](const json& j) {
    CaptureConfig c;
    try {
      config_from_json(j, "capture.json", c);
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("(no error)");
  };
  CHECK(error({{"cache", {{"budget_mbb", 5}}}}) == "capture.json: cache.budget_mbb: unknown key");
  CHECK(error({{"split_rule", "novel"}}) ==
        "capture.json: split_rule: unknown value \"novel\" (known: novel_pose, novel_view)");
  CHECK(error({{"hand", "each"}}) ==
        "capture.json: hand: unknown value \"each\" (known: right, left, both)");
  CHECK(error({{"frame_stride", 0}}) ==
        "capture.json: frame_stride: value 0 out of range [1, 1e+06]");
  CHECK(error({{"train_cameras", {400262}}}) ==
        "capture.json: train_cameras[0]: expected string, got number");
}
