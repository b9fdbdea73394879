// The synthetic capture: the built-in hand moving through a range-of-motion sequence, seen by a
// camera rig, rendered with the mesh rasteriser and written in exactly the InterHand2.6M layout
// (images/{split}/Capture{c}/{seq}/cam{id}/image{frame}.jpg and the four annotation files), so the
// real reader (data/capture.h) is what reads it back.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "data/synth_cameras.h"
#include "data/synth_config.h"
#include "data/synth_motion.h"
#include "data/synth_render.h"
#include "data/synth_skin.h"
#include "hand/rig.h"

namespace handscs {

struct SynthFrame {
  std::string seq_name;
  int64_t frame_idx = 0;
  SynthPose absolute;                  // absolute pose (flat_hand_mean = true) and shape
  std::array<double, 48> annotated{};  // as written: finger pose minus hands_mean
  std::array<double, 3> trans{};       // metres
  std::vector<float> vertices;         // [V * 3] posed, world metres
  std::vector<float> normals;          // [V * 3]
  std::vector<float> occlusion;        // [V] fold occlusion
  std::array<double, 63> joints{};     // MANO21 world joints (m)
};

struct SynthScene {
  SynthConfig config;
  Rig rig;
  SynthSkin skin;
  std::vector<int64_t> faces;  // [F * 3]
  std::vector<SynthCamera> cameras;
  std::vector<SynthFrame> frames;
};

// Poses the built-in right hand for every frame and places the cameras (no rendering).
SynthScene make_synth_scene(const SynthConfig& config);

// Renders frame `frame` from camera `camera` (deterministic: same pixels for any thread count).
SynthView render_synth_frame(const SynthScene& scene, int frame, int camera);

struct SynthReport {
  int64_t images = 0;
  int64_t bytes = 0;   // JPEG and JSON bytes written
  double seconds = 0;  // wall time of rendering and writing
};

// Writes the whole capture under out_dir (created if needed; existing files are replaced).
// Rendering runs in parallel over images (OpenMP); errors are collected and thrown afterwards.
SynthReport write_synth_capture(const SynthScene& scene, const std::string& out_dir);

// make_synth_scene + write_synth_capture, logging what was written (handscs-synth's body).
SynthReport generate_synth_capture(const SynthConfig& config, const std::string& out_dir);

}  // namespace handscs
