// The synthetic capture: the built-in hand moving through a range-of-motion sequence, seen by a
// camera rig, rendered with the mesh rasteriser and written in exactly the InterHand2.6M layout
// (images/{split}/Capture{c}/{seq}/cam{id}/image{frame}.jpg and the four annotation files), or in
// the project's own or EasyMocap's (SynthConfig::layout, synth/own_layouts.h), so the real reader
// (data/capture.h) is what reads it back.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "hand/rig.h"
#include "synth/camera_response.h"
#include "synth/cameras.h"
#include "synth/config.h"
#include "synth/forearm.h"
#include "synth/hand_axes.h"
#include "synth/motion.h"
#include "synth/render.h"
#include "synth/skin.h"
#include "synth/tissue.h"

namespace handscs {

struct SynthFrame {
  std::string seq_name;
  int64_t frame_idx = 0;
  std::string gesture;                 // the gesture the hand moves to ("" in range of motion)
  SynthPose absolute;                  // rendered absolute pose (flat_hand_mean = true) and shape
  std::array<double, 48> annotated{};  // as written: (pose + fit error) minus hands_mean
  std::array<double, 10> annotated_shape{};  // as written: shape + fit error
  std::array<double, 3> trans{};             // rendered translation (m)
  std::array<double, 3> annotated_trans{};   // as written: trans + fit error (m)
  std::vector<float> vertices;         // [V * 3] rendered hand (tissue included), world metres
  std::vector<float> normals;          // [V * 3]
  std::vector<float> occlusion;        // [V] fold occlusion (0 when off)
  std::vector<float> visibility;       // [V] key-light visibility (empty without cast shadows)
  std::vector<float> contact;          // [V] contact flattening, m (empty without tissue)
  std::vector<float> forearm;          // [V_f * 3] forearm, world metres (empty without it)
  std::vector<float> forearm_normals;  // [V_f * 3]
  std::array<double, 63> joints{};     // MANO21 world joints of the rendered pose (m): joint_3d
};

struct SynthScene {
  SynthConfig config;
  Rig rig;
  HandAxes axes;
  SynthSkin skin;
  std::vector<int64_t> faces;  // [F * 3] the hand's
  ForearmMesh forearm;         // empty without effects.forearm
  std::vector<SynthCamera> cameras;
  std::vector<CameraResponse> responses;  // per camera (identity without camera_response)
  std::vector<SynthFrame> frames;
  // hand both: the left hand of each frame (same order), in the world and in the built-in left
  // rig's terms (annotated pose relative to its hands_mean); empty for one hand. See make_synth_scene.
  std::vector<SynthFrame> left_frames;
};

// Poses the built-in right hand for every frame and places the cameras (no rendering). With hand
// both, a second motion (its own seed, the right hand's shape) is reflected through a plane across
// the thumbs into a left hand beside the right one, thumbs towards each other; the gap between
// the hands' boxes swings from an overlap to a few centimetres, so they touch and hide each other.
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

// make_synth_scene + write_synth_capture, logging what was written (handscs-synth's body). An
// out_dir that exists and is not empty is refused unless `overwrite`; the capture is written into a
// folder beside it and swapped in once complete, so a failure leaves out_dir as it was.
SynthReport generate_synth_capture(const SynthConfig& config, const std::string& out_dir,
                                   bool overwrite = false);

}  // namespace handscs
