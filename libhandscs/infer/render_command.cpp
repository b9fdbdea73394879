#include "infer/render_command.h"

#include <array>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <filesystem>

#include <CLI/CLI.hpp>
#include <c10/core/InferenceMode.h>
#include <spdlog/spdlog.h>
#include <torch/types.h>

#include "core/error.h"
#include "core/text.h"
#include "infer/avatar_render.h"
#include "io/ply.h"
#include "io/ply_check.h"
#include "io/png.h"
#include "render/camera_json.h"
#include "render/rasterize.h"

namespace handscs {

namespace {

// The PLY mode writes PNG: another extension would hold PNG bytes under a misleading name.
void require_png_name(const std::string& flag, const std::string& path) {
  require(lower_extension(path) == ".png", flag + " " + path + ": the PLY mode writes PNG images; name the file .png");
}

void run_ply_mode(const PlyMode& mode) {
  require_png_name("--out", mode.out);
  if (!mode.alpha.empty()) require_png_name("--alpha", mode.alpha);
  GaussianPly ply = read_gaussian_ply(mode.ply);
  const PlyCheck check = check_gaussian_ply(ply);
  require(check.total > 0, mode.ply + ": holds no Gaussians (0 vertices)");
  require(check.num_drawable() > 0, mode.ply + ": none of its Gaussians can be drawn (" + check.summary() + ")");
  if (check.num_drawable() < check.total) {
    spdlog::warn("{}: {}; they are left out", mode.ply, check.summary());
    ply = select_gaussians(ply, check.drawable);
  }
  if (!check.scale_warning().empty()) spdlog::warn("{}: {}", mode.ply, check.scale_warning());
  const Camera camera = read_camera_json(mode.camera);
  for (float c : mode.background)
    require(c >= 0 && c <= 1, "--background: values must be in [0, 1]");
  c10::InferenceMode guard;
  RasterSettings settings;
  settings.background = {mode.background[0], mode.background[1], mode.background[2]};
  const auto covariances = covariance_from_scale_rotation(ply_scales(ply), ply.rotations);
  const RasterOutput out =
      rasterize_gaussians(ply.means, covariances, ply_colors(ply), ply_opacities(ply),
                                   camera, settings);
  const int64_t visible = (out.radii > 0).sum().item<int64_t>();
  // An image of the background alone is no render of the scene: the camera looks elsewhere.
  require(visible > 0, mode.camera + ": none of the " + std::to_string(ply.size()) + " Gaussians of " +
                           mode.ply + " is in this camera's view (it faces away or sits inside or "
                           "beyond them); nothing written");
  write_png(mode.out, out.rgb);
  if (!mode.alpha.empty()) write_png(mode.alpha, out.alpha);
  spdlog::info("rendered {} Gaussians ({} visible) at {}x{} -> {}", ply.size(), visible,
               camera.width, camera.height, mode.out);
}

void run_avatar_mode(const AvatarMode& mode, const PlyMode& shared) {
  AvatarRenderOptions options;
  options.checkpoint = mode.checkpoint;
  options.poses = mode.poses;
  options.camera = shared.camera;
  options.orbit = mode.orbit;
  options.out_dir = shared.out;
  options.video = mode.video;
  options.video_fps = mode.video_fps;
  options.export_ply = mode.export_ply;
  options.ply_sh_degree = mode.ply_sh_degree;
  for (float c : shared.background)
    require(c >= 0 && c <= 1, "--background: values must be in [0, 1]");
  options.background = {shared.background[0], shared.background[1], shared.background[2]};
  require(!mode.poses.empty(), "avatar mode needs --poses POSES");
  const auto result = render_avatar(options);
  spdlog::info("rendered {} frames of {} Gaussians at {}x{}: {:.1f} FPS over the whole forward "
               "(median {:.1f} ms) -> {}", result.frames, result.gaussians, result.width, result.height,
               result.fps, result.forward_ms, shared.out);
}

// An option the chosen mode cannot use is an error, never silently ignored.
void check_mode_options(const PlyMode& ply, const AvatarMode& avatar) {
  std::vector<std::string> misplaced;
  if (!avatar.checkpoint.empty()) {
    if (!ply.ply.empty()) misplaced.push_back("--ply");
    if (!ply.alpha.empty()) misplaced.push_back("--alpha");
    require(misplaced.empty(), join(misplaced, ", ") +
                                            ": PLY-scene option(s), not used with --checkpoint (avatar mode); "
                                            "give one mode");
    return;
  }
  const AvatarMode defaults;
  if (!avatar.poses.empty()) misplaced.push_back("--poses");
  if (avatar.orbit != defaults.orbit) misplaced.push_back("--orbit");
  if (!avatar.video.empty()) misplaced.push_back("--video");
  if (avatar.video_fps != defaults.video_fps) misplaced.push_back("--fps");
  if (avatar.export_ply) misplaced.push_back("--export-ply");
  if (avatar.ply_sh_degree != defaults.ply_sh_degree) misplaced.push_back("--ply-sh-degree");
  require(misplaced.empty(), join(misplaced, ", ") +
                                          ": avatar-mode option(s), used only with --checkpoint");
}

}  // namespace

void add_ply_mode(CLI::App& app, PlyMode& mode) {
  auto* group = app.add_option_group("PLY scene", "render a 3D Gaussian Splatting PLY from one camera");
  group->add_option("--ply", mode.ply, "3DGS PLY file (x y z, f_dc_*, opacity, scale_*, rot_*)");
  group->add_option("--camera", mode.camera, "camera JSON: {\"K\": 3x3, \"R\": 3x3, \"t\": [3], \"width\", \"height\"}");
  group->add_option("--out", mode.out, "output RGB PNG");
  group->add_option("--alpha", mode.alpha, "also write the alpha channel as a grey PNG");
  group->add_option("--background", mode.background, "background colour R G B in [0, 1] (default 0 0 0)")
      ->expected(3);
}

void add_avatar_mode(CLI::App& app, AvatarMode& mode) {
  auto* group = app.add_option_group(
      "Avatar", "a trained avatar in new poses and views (uses --camera, --out DIR and --background)");
  group->add_option("--checkpoint", mode.checkpoint, "checkpoint file or run folder (its newest checkpoint)");
  group->add_option("--poses", mode.poses,
                    "POSES JSON: {\"poses\": [{\"pose\": [48], \"shape\": [10], \"trans\": [3]}, ...]}, "
                    "{\"interpolate\": {\"from\", \"to\", \"steps\"}}, {\"capture\": {...}, \"frames\": \"test\"}, or "
                    "a keypoint file (format handscs-keypoints) fitted with the avatar's rig (docs/FIT.md). A "
                    "two-hand avatar takes each pose as {\"right\": {pose...}, \"left\": {pose...}} (also in "
                    "\"from\" and \"to\"), and fits each hand of a keypoint file");
  // At most 100,000 views (nearly an hour of 30 FPS video): a larger number is a typo that would
  // run for days.
  group->add_option("--orbit", mode.orbit, "N turntable views around the hand (instead of --camera)")
      ->check(CLI::Range(1, 100000));
  group->add_option("--video", mode.video, "also write the frames as an MP4 video");
  // 1-240 FPS: what MP4 players and screens show; 0, a negative or a NaN rate made the video
  // writer fail with a GStreamer assertion.
  group->add_option("--fps", mode.video_fps, "frame rate of the video, 1-240 (default 30)")
      ->check(CLI::Validator(
          [](std::string& text) {
            char* end = nullptr;
            const double fps = std::strtod(text.c_str(), &end);
            return end != text.c_str() && *end == 0 && std::isfinite(fps) && fps >= 1 && fps <= 240
                       ? std::string()
                       : "--fps " + text + ": a frame rate in [1, 240]";
          },
          "FPS", "frame rate"));
  group->add_flag("--export-ply", mode.export_ply, "also write each frame's posed Gaussians as a 3DGS PLY");
  group->add_option("--ply-sh-degree", mode.ply_sh_degree,
                    "SH degree the PLY declares (default 0: f_dc only; 3 adds 45 zero f_rest, which "
                    "the original 3DGS code's load_ply expects; the picture is the same)")
      ->check(CLI::Range(0, kMaxPlyShDegree));
}

void run_render_command(const PlyMode& ply, const AvatarMode& avatar) {
  check_mode_options(ply, avatar);
  if (!avatar.checkpoint.empty()) {
    run_avatar_mode(avatar, ply);
    return;
  }
  require(!ply.ply.empty() && !ply.camera.empty() && !ply.out.empty(),
          "nothing to render: give --ply, --camera and --out (see --help)");
  run_ply_mode(ply);
}

}  // namespace handscs
