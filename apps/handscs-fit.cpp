// handscs-fit: the hand rig fitted to 3D keypoints or multi-view 2D landmarks (docs/FIT.md).
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>

#include "core/cli.h"
#include "fit/fit_command.h"

int main(int argc, char** argv) {
  CLI::App app{
      "handscs-fit: fits the hand rig (pose per frame, one shape) to 3D keypoints or to multi-view 2D "
      "landmarks, for the right and left hand; writes POSES files for handscs-render / handscs-view, "
      "report.json / report.csv (residual per joint in mm, skipped frames and why) and, for a multi-view "
      "capture, capture.json, reprojection errors and the fitted meshes over the photographs; for a keypoint file "
      "with --capture-dir, that capture with the fitted hands"};
  handscs::CommonOptions common;
  handscs::FitCommandOptions options;
  handscs::add_common_options(app, common, true);
  app.add_option("--keypoints", options.keypoints,
                 "3D keypoint file (JSON, format handscs-keypoints: order and units stated in the file)");
  app.add_option("--interhand-joints", options.interhand_joints, "InterHand2.6M joint_3d.json (with --capture)");
  app.add_option("--capture", options.capture, "capture number in --interhand-joints");
  app.add_option("--multiview", options.multiview,
                 "multi-view capture folder: camera/param.npz (or cameras.npz), img/NN.png, pose/NN.json "
                 "(MediaPipe landmarks per view); a sequence holds img/ and pose/ in a folder per instant "
                 "(<frame>/img/NN.png), fitted with one shape per hand");
  app.add_option("--capture-dir", options.capture_dir,
                 "with --keypoints: a capture in the project's or EasyMocap's layout (its frames may carry no hands) "
                 "whose frames the keypoint file's frame names number; --out gets it with the fitted hands, to train on");
  app.add_option("--out", options.out, "output folder (refused when not empty, unless --overwrite)")->required();
  app.add_flag("--overwrite", options.overwrite, "replace the fit in a non-empty --out");
  app.add_option("--config", options.config, "JSON file of fit settings (keys: docs/FIT.md); --set overrides keys");
  app.add_option("--rig-right", options.rig_right, "right-hand rig: builtin, builtin+fingers (per-finger length modes) or a rig file (docs/RIG_FORMAT.md)");
  app.add_option("--rig-left", options.rig_left, "left-hand rig: builtin:left, builtin+fingers:left or a rig file");
  app.add_flag("--flat-hand-mean", options.flat_hand_mean,
               "write absolute poses (default: relative to the rig's hands_mean, as InterHand2.6M's)");
  app.add_option("--overlay-views", options.overlay_views,
                 "multi-view: view indices to draw the fitted meshes over (default: 4 spread views)");
  app.add_option("--overlay-frame", options.overlay_frame,
                 "multi-view sequence: the frame (its folder's number) drawn over (default: the first fitted)")
      ->check(CLI::NonNegativeNumber);
  CLI11_PARSE(app, argc, argv);
  options.overrides = common.overrides;
  try {
    handscs::start_up(common, "handscs-fit");
    handscs::run_fit_command(options);
  } catch (const std::exception& e) {
    spdlog::error("{}", handscs::error_text(e));
    return 1;
  }
  return 0;
}
