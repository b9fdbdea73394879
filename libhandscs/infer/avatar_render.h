// handscs-render's avatar mode: a trained avatar in new poses and views. Writes per frame RGB and
// alpha PNGs, optionally an MP4 (OpenCV VideoWriter) and the posed Gaussians as 3DGS PLY files, and
// measures frames per second over the whole forward (LBS, SCS, decoders, rasterizer).
#pragma once

#include <array>
#include <string>

namespace handscs {

// 3DGS stores spherical harmonics up to degree 3; no reader expects more.
constexpr int kMaxPlyShDegree = 3;

struct AvatarRenderOptions {
  std::string checkpoint;  // file, or run folder (latest checkpoint)
  std::string poses;       // POSES file (infer/pose_source.h)
  std::string camera;      // camera JSON (K, R, t, width, height); or
  int orbit = 0;           // N turntable views around the hand; or the capture frames' own cameras
  std::string out_dir;     // frame_XXXX.png, frame_XXXX_alpha.png, frame_XXXX_camera.json (the
                           // frame's camera, render/camera_json.h) and transforms.json (all of
                           // them for nerfstudio and other tools, render/camera_export.h)
  std::string video;       // MP4 path ("" = none)
  double video_fps = 30;
  bool export_ply = false;  // frame_XXXX.ply with the posed Gaussians
  // Spherical-harmonics degree the PLY declares: 0 writes f_dc only (web viewers); d > 0 adds the
  // 3((d + 1)^2 - 1) f_rest properties as zeros (the colours are view-independent, so the picture
  // is the same) for readers that insist on them, e.g. the original 3DGS code at its default 3.
  int ply_sh_degree = 0;
  std::array<float, 3> background{0, 0, 0};
};

struct AvatarRenderResult {
  int64_t frames = 0;
  double fps = 0;           // frames / total forward seconds
  double forward_ms = 0;    // median forward per frame
  int64_t gaussians = 0;
  int width = 0, height = 0;
};

// Frames = max(#poses, #cameras); frame k uses pose k mod #poses and camera k mod #cameras.
AvatarRenderResult render_avatar(const AvatarRenderOptions& options);

}  // namespace handscs
