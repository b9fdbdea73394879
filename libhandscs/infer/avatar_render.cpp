#include "infer/avatar_render.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <optional>

#include <spdlog/spdlog.h>
#include <torch/types.h>
#include <torch/linalg.h>  // after types.h: it is not self-contained

#include "avatar/avatar.h"
#include "infer/posed_hands.h"
#include "core/atomic_file.h"
#include "core/error.h"
#include "core/progress.h"
#include "core/stop_signal.h"
#include "data/mesh_mask.h"
#include "infer/pose_source.h"
#include "io/mp4_writer.h"
#include "io/ply.h"
#include "io/png.h"
#include "metrics/image_tensor.h"
#include "render/camera_export.h"
#include "render/camera_json.h"
#include "render/orbit.h"
#include "run/avatar_state_io.h"
#include "run/camera_color_transform.h"

namespace handscs {

namespace {

// Posed Gaussians as 3DGS PLY: scales and rotation from the eigen-decomposition of each covariance.
void write_posed_ply(const std::string& path, const PosedGaussians& p, int sh_degree) {
  const auto c = p.covariances;
  const auto cov = torch::stack({c.select(1, 0), c.select(1, 1), c.select(1, 2), c.select(1, 1),
                                 c.select(1, 3), c.select(1, 4), c.select(1, 2), c.select(1, 4),
                                 c.select(1, 5)}, 1).view({-1, 3, 3}).to(torch::kFloat64);
  auto [eigenvalues, eigenvectors] = torch::linalg::eigh(cov, "L");
  // A proper rotation (det +1): flip the last axis where the eigenvector basis is a reflection.
  const auto det = torch::linalg::det(eigenvectors);
  eigenvectors.select(2, 2).mul_(torch::where(det < 0, -1.0, 1.0).unsqueeze(1));
  const auto r = eigenvectors;
  // Rotation matrix -> quaternion (w, x, y, z), robust branch-free form via copysign.
  const auto m00 = r.select(1, 0).select(1, 0), m11 = r.select(1, 1).select(1, 1),
             m22 = r.select(1, 2).select(1, 2);
  const auto w = (1 + m00 + m11 + m22).clamp_min(0).sqrt() / 2;
  auto x = (1 + m00 - m11 - m22).clamp_min(0).sqrt() / 2;
  auto y = (1 - m00 + m11 - m22).clamp_min(0).sqrt() / 2;
  auto z = (1 - m00 - m11 + m22).clamp_min(0).sqrt() / 2;
  x = torch::copysign(x, r.select(1, 2).select(1, 1) - r.select(1, 1).select(1, 2));
  y = torch::copysign(y, r.select(1, 0).select(1, 2) - r.select(1, 2).select(1, 0));
  z = torch::copysign(z, r.select(1, 1).select(1, 0) - r.select(1, 0).select(1, 1));
  const auto quats = torch::stack({w, x, y, z}, 1).to(torch::kFloat32);
  const auto scales = eigenvalues.clamp_min(1e-20).sqrt().to(torch::kFloat32);
  GaussianPly ply = make_gaussian_ply(p.means.to(torch::kFloat32),
                                      p.colors.clamp(0, 1).to(torch::kFloat32),
                                      p.opacities.to(torch::kFloat32), scales, quats);
  if (sh_degree > 0)
    ply.f_rest = torch::zeros({ply.size(), 3 * ((sh_degree + 1) * (sh_degree + 1) - 1)},
                              torch::kFloat32);
  write_gaussian_ply(path, ply);
}

// Frames whose hand is out of view are logged by name up to this many times (then counted).
constexpr int64_t kOutOfViewLines = 5;

// Where a frame's camera came from, for messages.
std::string camera_source(const AvatarRenderOptions& options, const PoseFrame& f, int64_t k,
                          int64_t cameras) {
  if (!options.camera.empty()) return options.camera;
  if (options.orbit > 0) return "--orbit view " + std::to_string(k % cameras);
  return "the capture camera of " + f.name;
}

std::string frame_name(int64_t k) {
  char name[32];
  std::snprintf(name, sizeof(name), "frame_%04lld", static_cast<long long>(k));
  return name;
}

}  // namespace

AvatarRenderResult render_avatar(const AvatarRenderOptions& options) {
  require(!options.out_dir.empty(), "--out DIR is required");
  require(options.ply_sh_degree >= 0 && options.ply_sh_degree <= kMaxPlyShDegree,
          "--ply-sh-degree " + std::to_string(options.ply_sh_degree) + ": must be 0.." +
              std::to_string(kMaxPlyShDegree));
  TrainedAvatar trained = open_trained_avatar(options.checkpoint);
  const std::vector<PoseFrame> poses = read_poses_for_avatar(options.poses, trained);
  PosedHands hands(trained);

  std::vector<Camera> cameras;
  if (!options.camera.empty()) {
    cameras.push_back(read_camera_json(options.camera));
  } else if (options.orbit > 0) {
    // Orbit around the first pose: centre and long axis from its posed joints.
    c10::InferenceMode guard;
    const auto& f = poses.front();
    const PosedGaussians posed = hands.pose(f, options.poses);
    const AvatarState* first = hands.state(Handedness::right) ? hands.state(Handedness::right)
                                                              : hands.state(Handedness::left);
    const auto joints = first->lbs.joints[0].to(torch::kFloat64);
    const auto means = posed.means.to(torch::kFloat64);
    const auto centre = means.mean(0);
    const auto axis = joints[18] - joints[0];  // wrist -> middle fingertip (MANO21)
    const double extent = (means.amax(0) - means.amin(0)).norm().item<double>();
    OrbitSpec spec;
    spec.count = options.orbit;
    cameras = orbit_cameras({centre[0].item<double>(), centre[1].item<double>(), centre[2].item<double>()},
                            {axis[0].item<double>(), axis[1].item<double>(), axis[2].item<double>()},
                            extent, spec);
  } else {
    for (const auto& f : poses)
      require(f.camera.has_value(),
              "no camera: give --camera CAM.json or --orbit N (or a POSES capture selection)");
  }

  ensure_directory(options.out_dir);
  const int64_t count = std::max<int64_t>(poses.size(), cameras.empty() ? poses.size() : cameras.size());
  // Opened before the first frame, so a target that cannot be written is named before any work.
  std::optional<Mp4Writer> video;
  if (!options.video.empty()) video.emplace(options.video, options.video_fps);
  AvatarRenderResult result;
  RasterSettings settings;
  settings.background = options.background;
  std::vector<double> forward_ms;
  int64_t out_of_view = 0;
  std::vector<CameraFrame> frame_cameras;  // every frame's camera, for transforms.json
  // train.camera_color: a capture camera the avatar trained on renders through its colour
  // transform; any other camera (--camera, --orbit, an unseen capture camera) shows the avatar's
  // own colours. PLYs always hold the avatar's own colours.
  int64_t transformed = 0;
  ProgressBar bar("render", count);
  // Ctrl-C, SIGTERM or SIGHUP: the frames written so far stay (each PNG is whole), the video is
  // dropped (Mp4Writer removes its temporary file) and the render ends with an error saying where.
  const StopSignal stop_signal;
  c10::InferenceMode guard;
  for (int64_t k = 0; k < count; ++k) {
    if (StopSignal::requested())
      throw Error("render interrupted (SIGINT, SIGTERM or SIGHUP) after " + std::to_string(k) + " of " +
                  std::to_string(count) + " frames, kept in " + options.out_dir +
                  (video ? "; the video was not written" : ""));
    const PoseFrame& f = poses[k % poses.size()];
    const Camera camera = cameras.empty() ? *f.camera : cameras[k % cameras.size()];
    // Posed once per pose (an orbit shows one pose from every camera); each frame's forward time
    // is its pose's full cost plus its rasterisation.
    AvatarOutput out;
    out.state.posed = hands.pose(f, options.poses + ": " + f.name);
    const auto t0 = std::chrono::steady_clock::now();
    out.render = render_posed(out.state.posed, camera, settings);
    if (cameras.empty() && !f.camera_id.empty())
      if (const auto transform = trained.colors.find(f.camera_id)) {
        out.render.rgb = apply_color_transform(out.render.rgb, out.render.alpha, settings.background,
                                               *transform);
        ++transformed;
      }
    forward_ms.push_back(hands.pose_ms() + std::chrono::duration<double, std::milli>(
                                              std::chrono::steady_clock::now() - t0).count());
    {
      // A camera facing away, or a pose far off: the posed Gaussians miss the image entirely.
      const auto means = out.state.posed.means.to(torch::kFloat32).contiguous();
      if (projected_bounds(means.data_ptr<float>(), means.size(0), camera).empty() &&
          ++out_of_view <= kOutOfViewLines)
        spdlog::warn("{}: the hand of pose {} is not in view of {} (behind the camera or outside "
                     "its image): background only", frame_name(k), f.name,
                     camera_source(options, f, k, static_cast<int64_t>(cameras.size())));
    }
    const cv::Mat rgb = rgb_tensor_to_mat(out.render.rgb.clamp(0, 1));
    const auto alpha8 = out.render.alpha.clamp(0, 1).mul(255).round().to(torch::kUInt8).contiguous();
    const cv::Mat alpha(alpha8.size(0), alpha8.size(1), CV_8UC1, alpha8.data_ptr<uint8_t>());
    const std::string base = options.out_dir + "/" + frame_name(k);
    write_png(base + ".png", rgb);
    write_png(base + "_alpha.png", alpha);
    if (options.export_ply) write_posed_ply(base + ".ply", out.state.posed, options.ply_sh_degree);
    write_camera_json(base + "_camera.json", camera);
    frame_cameras.push_back({frame_name(k) + ".png", camera});
    if (video) video->write(rgb);
    result.width = camera.width;
    result.height = camera.height;
    bar.update(k + 1);
  }
  bar.finish();
  if (out_of_view == count) {
    if (video) video->abandon();
    throw Error("no frame shows the hand: in all " + std::to_string(count) + " frames it is behind " +
                "the camera or outside the image (" +
                camera_source(options, poses.front(), 0, static_cast<int64_t>(cameras.size())) +
                "); check the camera's R and t against the poses' trans (" + options.out_dir +
                " holds background-only images)");
  }
  if (!trained.colors.matrices.empty())
    spdlog::info("colours: the {} transform of its training camera on {} of {} frames, the avatar's "
                 "own colours on the others", camera_color_name(trained.colors.mode), transformed,
                 count);
  if (out_of_view > kOutOfViewLines)
    spdlog::warn("{} of {} frames show no hand (the first {} are named above)", out_of_view, count,
                 kOutOfViewLines);
  if (video) video->finish();
  write_file_atomic(options.out_dir + "/transforms.json",
                    nerfstudio_transforms(frame_cameras).dump(2));
  result.frames = count;
  result.gaussians = trained.gaussian_count();
  double total = 0;
  for (double ms : forward_ms) total += ms;
  result.fps = total > 0 ? count / (total / 1000.0) : 0;
  std::sort(forward_ms.begin(), forward_ms.end());
  result.forward_ms = forward_ms.empty() ? 0 : forward_ms[forward_ms.size() / 2];
  return result;
}

}  // namespace handscs
