// Settings of a synthetic InterHand2.6M-layout capture (handscs-synth) and its named presets: the
// easy tiny/demo/bench captures (the rig's own hand under fixed light) and the realistic
// real_tiny/real_demo/real_bench ones, whose ground truth differs from the rig (synth/effects.h).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "data/capture_config.h"
#include "synth/effects.h"

namespace handscs {

struct SynthConfig {
  std::string preset = "tiny";
  int num_cameras = 4;
  int num_frames = 12;            // poses (frames) over the whole capture
  int num_sequences = 1;          // frames are split evenly into this many sequences
  int width = 334, height = 512;  // portrait size; landscape cameras swap the two
  double focal = 1265.0;  // px at 334x512 (InterHand cameras: 1260-1275 px); scales with size
  double camera_distance = 1.05;  // m from the hand centre (InterHand: joints at 1.0-1.2 m depth)
  int landscape_every = 3;        // every k-th camera is landscape (0 = none)
  int64_t seed = 1;
  int supersample = 3;  // odd: the centre sub-sample of each pixel is its centre
  int jpeg_quality = 95;
  std::string split = "test";  // images/{split}/, annotations/{split}/
  int capture = 0;             // Capture{c}
  int frame_step = 6;          // frame_idx step (the 5 fps release keeps every 6th 30 fps frame)
  int held_out_frames = 50;    // the novel-pose test tail (data.held_out_poses): gestures only
  // "left": the right-hand capture mirrored through the world's x = 0 plane (synth/mirror.h), so a
  // left-hand capture is the exact mirror image of the right one with the same settings. "both": a
  // left hand beside the right one, moving on its own (synth/left_hand.h).
  CaptureConfig::Hands hand = CaptureConfig::Hands::right;
  // Files written (docs/CAPTURE_FORMAT.md): InterHand2.6M's, the project's own, or EasyMocap's
  // (whose images carry a known lens distortion, synth/own_layouts.h).
  CaptureConfig::Layout layout = CaptureConfig::Layout::interhand;
  SynthEffects effects;

  template <class V>
  void visit(V& v) {
    v.field("preset", preset, "preset the values started from");
    v.field("num_cameras", num_cameras, "cameras on the rig", 1, 1000);
    v.field("num_frames", num_frames, "poses over the whole capture", 1, 1000000);
    v.field("num_sequences", num_sequences, "sequences the frames are split into", 1, 1000);
    v.field("width", width, "portrait image width (px)", 16, 8192);
    v.field("height", height, "portrait image height (px)", 16, 8192);
    v.field("focal", focal, "focal length at 334 px width (px)", 1, 1e6);
    v.field("camera_distance", camera_distance, "camera distance from the hand (m)", 0.1, 100);
    v.field("landscape_every", landscape_every, "every k-th camera is landscape (0 = none)", 0,
            1000);
    v.field("seed", seed, "seed of motion, cameras, shape and noise");
    v.field("supersample", supersample, "odd sub-samples per pixel side", 1, 9);
    v.field("jpeg_quality", jpeg_quality, "JPEG quality", 1, 100);
    v.choice("split", split, {"train", "test", "val"}, "split folder");
    v.field("capture", capture, "capture number", 0, 1000000);
    v.field("frame_step", frame_step, "frame_idx step between frames", 1, 1000);
    v.field("held_out_frames", held_out_frames, "frames of the held-out tail", 0, 1000000);
    v.choice("hand", hand, CaptureConfig::hand_names(),
             "hand in the capture (left: the right-hand capture mirrored through x = 0; both: a "
             "left hand beside the right one, thumbs close; the both_ presets frame them)");
    v.choice("layout", layout, layout_names(),
             "files written: InterHand2.6M's layout, the project's own, or EasyMocap's (with a "
             "known lens distortion)");
    v.section("effects", effects, "how the ground truth differs from the rig");
  }

  // The layouts a capture can be written in (data.layout's, without auto).
  static const ChoiceNames<CaptureConfig::Layout>& layout_names();
};

// Named presets: "tiny" (4 cameras x 12 frames, 167x256, for CI), "demo" (12 x 100, 334x512),
// "bench" (24 x 150, 334x512), "paper" (30 x 400, 334x512: the paper's scale), and "real_tiny",
// "real_demo", "real_bench", "real_paper" of the same sizes with every effect of synth/effects.h
// on. "both_" after any "real_" (e.g. "real_both_demo") gives two hands (hand both) with the
// cameras further away. Throws Error listing the known names for anything else.
SynthConfig synth_preset(const std::string& name);

// `config` with "key.path=value" overrides applied (handscs-synth --set); unknown keys and values
// out of range are errors naming the override.
SynthConfig apply_synth_overrides(const SynthConfig& config,
                                  const std::vector<std::string>& overrides);
std::vector<std::string> synth_preset_names();

// Throws Error naming the keys when a capture would be too large to generate here (more frames,
// images or pixels than any InterHand2.6M capture), before anything is allocated.
void check_synth_size(const SynthConfig& config);

}  // namespace handscs
