// handscs-render on the command line: two modes, each an option group. PLY scene: --ply --camera
// --out [--alpha] [--background]; avatar: --checkpoint --poses (--camera | --orbit N) --out DIR
// [--video] [--export-ply] [--ply-sh-degree] (--camera, --out and --background are shared).
#pragma once

#include <string>
#include <vector>

namespace CLI {
class App;
}

namespace handscs {

struct PlyMode {
  std::string ply;     // 3DGS PLY file
  std::string camera;  // camera JSON
  std::string out;     // RGB PNG
  std::string alpha;   // optional alpha PNG
  std::vector<float> background{0, 0, 0};
};

struct AvatarMode {
  std::string checkpoint;
  std::string poses;
  int orbit = 0;
  std::string video;
  double video_fps = 30;
  bool export_ply = false;
  int ply_sh_degree = 0;
};

// Add the "PLY scene" and "Avatar" option groups.
void add_ply_mode(CLI::App& app, PlyMode& mode);
void add_avatar_mode(CLI::App& app, AvatarMode& mode);

// Runs the mode the options choose. An option the chosen mode cannot use is an Error, never
// silently ignored; so is giving neither mode.
void run_render_command(const PlyMode& ply, const AvatarMode& avatar);

}  // namespace handscs
