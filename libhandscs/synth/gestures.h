// Gesture sequences like InterHand2.6M's: keyframes drawn from a vocabulary of hand gestures (fist,
// point, pinch, thumb to each fingertip, counting, spread, ...) joined by eased transitions in
// which every finger moves on its own timing, with the wrist turning slowly throughout. The
// held-out tail of the capture draws half its keyframes from gestures that training never sees.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "hand/rig.h"
#include "synth/motion.h"

namespace handscs {

struct Gesture {
  std::string name;
  // Flexion as fractions of the full range (MCP, PIP, DIP) of index, middle, ring, pinky.
  std::array<std::array<double, 3>, 4> fingers{};
  double spread = 0;      // fraction of the full abduction, -1..1
  double opposition = 0;  // thumb opposition fraction, 0..1
  double thumb_flex = 0;  // thumb MCP/IP flexion fraction, 0..1
  bool held_out_only = false;  // appears only in the held-out tail
};

// The vocabulary; gestures with held_out_only never appear in the first
// num_frames - held_out_frames frames.
const std::vector<Gesture>& gesture_vocabulary();

// The articulation of a gesture's fractions (fingers, spread, opposition, thumb flexion) in radians
// of each joint group's full range; the wrist is left at zero.
HandArticulation gesture_articulation(const Gesture& gesture);

// num_frames poses; the last held_out_frames are the novel-pose test tail. Shapes are those of
// make_rom_poses with the same seed. Also returns, per frame, the keyframe gesture it moves to.
std::vector<SynthPose> make_gesture_poses(const Rig& rig, int num_frames, int held_out_frames,
                                          uint64_t seed, std::vector<std::string>* gesture_names);

}  // namespace handscs
