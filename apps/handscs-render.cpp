// handscs-render: renders Gaussians to images. Each mode is an option group with its own run function:
//   PLY scene:  --ply scene.ply --camera camera.json --out image.png [--alpha alpha.png] [--background R G B]
//   Avatar:     --checkpoint CKPT|RUN_DIR --poses POSES (--camera camera.json | --orbit N) --out DIR
//               [--video out.mp4] [--export-ply]   (--camera, --out and --background are shared)
#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include "core/cli.h"
#include "infer/render_command.h"

int main(int argc, char** argv) {
  CLI::App app{"handscs-render: render Gaussians to images"};
  handscs::CommonOptions common;
  handscs::add_common_options(app, common, false);
  handscs::PlyMode ply;
  handscs::add_ply_mode(app, ply);
  handscs::AvatarMode avatar;
  handscs::add_avatar_mode(app, avatar);
  CLI11_PARSE(app, argc, argv);
  try {
    handscs::start_up(common, "handscs-render");
    handscs::run_render_command(ply, avatar);
  } catch (const std::exception& e) {
    spdlog::error("{}", handscs::error_text(e));
    return 1;
  }
  return 0;
}
