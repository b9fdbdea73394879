#include "synth/gestures.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "hand/joint_order.h"

namespace handscs {

namespace {

// Full ranges (rad) of active flexion: MCP ~85, PIP ~100, DIP ~65 degrees (clinical range of
// motion of the fingers, slightly inside the maxima); finger abduction ~12 degrees either way;
// thumb opposition reaches the pinky at ~70 degrees about the long axis.
constexpr double kMcpRange = 1.48, kPipRange = 1.72, kDipRange = 1.12, kSpreadRange = 0.21;
constexpr double kOppositionRange = kFullOpposition, kThumbMcpRange = 0.7, kThumbIpRange = 1.0;
// Frames (5 fps) of a transition and of a hold: a gesture change takes about a second.
constexpr int kMinTransition = 4, kMaxTransition = 7, kMaxHold = 2;
// Per-keyframe jitter of each finger's flexion fractions, so no two keyframes are identical.
constexpr double kJitter = 0.06;
// Each finger starts its transition up to this many frames late: fingers move independently.
constexpr double kMaxLag = 1.0;

Gesture make(const std::string& name, std::array<double, 3> index, std::array<double, 3> middle,
             std::array<double, 3> ring, std::array<double, 3> pinky, double spread,
             double opposition, double thumb_flex, bool held_out_only = false) {
  Gesture g;
  g.name = name;
  g.fingers = {index, middle, ring, pinky};
  g.spread = spread;
  g.opposition = opposition;
  g.thumb_flex = thumb_flex;
  g.held_out_only = held_out_only;
  return g;
}

constexpr std::array<double, 3> kStraight = {0, 0, 0}, kRelaxed = {0.2, 0.25, 0.2},
                                kCurled = {0.95, 0.95, 0.8};

double ease(double t) {
  t = std::clamp(t, 0.0, 1.0);
  return t * t * (3 - 2 * t);
}

}  // namespace

const std::vector<Gesture>& gesture_vocabulary() {
  // Thumb-to-fingertip: the target finger bends towards the thumb, opposition grows towards the
  // pinky.
  static const std::vector<Gesture> vocabulary = {
      make("flat", kStraight, kStraight, kStraight, kStraight, 0, 0.1, 0.1),
      make("relaxed", kRelaxed, kRelaxed, kRelaxed, kRelaxed, 0.1, 0.3, 0.3),
      make("fist", kCurled, kCurled, kCurled, kCurled, -0.2, 0.6, 0.8),
      make("point", kStraight, kCurled, kCurled, kCurled, 0, 0.5, 0.7),
      make("spread", kStraight, kStraight, kStraight, kStraight, 1.0, 0.0, 0.0),
      make("peace", kStraight, kStraight, kCurled, kCurled, 0.8, 0.7, 0.6),
      make("pinch_index", {0.45, 0.5, 0.3}, kRelaxed, kRelaxed, kRelaxed, 0, 0.6, 0.4),
      make("thumb_middle", kRelaxed, {0.5, 0.55, 0.3}, kRelaxed, kRelaxed, 0, 0.75, 0.45),
      make("tabletop", {0.9, 0, 0}, {0.9, 0, 0}, {0.9, 0, 0}, {0.9, 0, 0}, 0, 0.3, 0.2),
      make("three", kStraight, kStraight, kCurled, kCurled, 0.4, 0.0, 0.0),
      make("thumbs_up", kCurled, kCurled, kCurled, kCurled, 0, 0.0, 0.0),
      make("ok", {0.5, 0.6, 0.4}, kStraight, kStraight, kStraight, 0.5, 0.65, 0.4),
      // Held out: articulations training never shows.
      make("thumb_ring", kRelaxed, kRelaxed, {0.55, 0.6, 0.3}, {0.3, 0.3, 0.2}, 0, 0.88, 0.5, true),
      make("thumb_pinky", kRelaxed, kRelaxed, {0.35, 0.35, 0.2}, {0.6, 0.6, 0.35}, 0, 1.0, 0.55,
           true),
      make("rock", kStraight, kCurled, kCurled, kStraight, 0.6, 0.6, 0.7, true),
      make("hook", {0, 0.95, 0.8}, {0, 0.95, 0.8}, {0, 0.95, 0.8}, {0, 0.95, 0.8}, 0, 0.3, 0.3,
           true),
      make("claw", {0.2, 0.6, 0.7}, {0.2, 0.6, 0.7}, {0.2, 0.6, 0.7}, {0.2, 0.6, 0.7}, 0.7, 0.2,
           0.5, true),
      make("cascade", kStraight, {0.3, 0.3, 0.25}, {0.6, 0.65, 0.5}, {0.9, 0.95, 0.8}, 0.2, 0.4,
           0.4, true),
  };
  return vocabulary;
}

HandArticulation gesture_articulation(const Gesture& gesture) {
  HandArticulation art;
  const double ranges[3] = {kMcpRange, kPipRange, kDipRange};
  for (int f = 0; f < 4; ++f)
    for (int j = 0; j < 3; ++j) art.flex[f + 1][j] = ranges[j] * gesture.fingers[f][j];
  for (int f = 1; f < kFingers; ++f) art.spread[f] = kSpreadRange * gesture.spread;
  art.thumb_opposition = kOppositionRange * gesture.opposition;
  art.flex[kThumb] = {0.25 * gesture.opposition, kThumbMcpRange * gesture.thumb_flex,
                      kThumbIpRange * gesture.thumb_flex};
  return art;
}

std::vector<SynthPose> make_gesture_poses(const Rig& rig, int num_frames, int held_out_frames,
                                          uint64_t seed, std::vector<std::string>* gesture_names) {
  require(num_frames > 0, "make_gesture_poses: num_frames must be positive");
  const int train_frames = std::max(0, num_frames - std::max(0, held_out_frames));
  const HandAxes axes = rig_axes(rig);
  const std::vector<Gesture>& vocabulary = gesture_vocabulary();
  std::vector<int> seen, unseen;
  for (int i = 0; i < static_cast<int>(vocabulary.size()); ++i)
    (vocabulary[i].held_out_only ? unseen : seen).push_back(i);
  SynthRandom random(mix_seed(seed, 0x676573747572));  // "gesture"

  // Keyframes: (frame it is reached at, gesture, jittered fractions). Frame 0 is `relaxed`.
  struct Key {
    double frame;
    int gesture;
    std::array<std::array<double, 3>, 4> fingers;
    double spread, opposition, thumb_flex;
    std::array<double, 5> lag;
  };
  auto jittered = [&](int g, double frame) {
    const Gesture& G = vocabulary[g];
    Key key{frame, g, G.fingers, G.spread, G.opposition, G.thumb_flex, {}};
    for (auto& finger : key.fingers)
      for (double& x : finger) x = std::clamp(x + kJitter * random.normal(), -0.05, 1.0);
    key.spread = std::clamp(key.spread + kJitter * random.normal(), -1.0, 1.0);
    key.opposition = std::clamp(key.opposition + kJitter * random.normal(), 0.0, 1.0);
    key.thumb_flex = std::clamp(key.thumb_flex + kJitter * random.normal(), 0.0, 1.0);
    for (double& l : key.lag) l = random.uniform(0, kMaxLag);
    return key;
  };
  std::vector<Key> keys = {jittered(1, 0)};
  double frame = 0;
  bool alternate = false;
  while (frame < num_frames) {
    const int hold = static_cast<int>(random.uniform(0, kMaxHold + 1));
    if (hold > 0) {  // hold the current gesture
      keys.push_back(keys.back());
      keys.back().frame = frame += hold;
    }
    double next = frame + kMinTransition + random.uniform(0, kMaxTransition - kMinTransition);
    // The last training keyframe lands on the boundary, so no transition towards an unseen
    // gesture starts inside the training frames; too close to it for a transition, the hand
    // holds its gesture until the tail starts.
    if (frame < train_frames && next > train_frames) {
      if (train_frames - frame < kMinTransition) {
        keys.push_back(keys.back());
        keys.back().frame = frame = train_frames;
        continue;
      }
      next = train_frames;
    }
    // In the held-out tail every other keyframe is an unseen gesture.
    const bool tail = frame >= train_frames;
    int g;
    do {
      alternate = !alternate;
      const std::vector<int>& pool = tail && alternate && !unseen.empty() ? unseen : seen;
      g = pool[static_cast<size_t>(random.uniform() * pool.size()) % pool.size()];
    } while (g == keys.back().gesture);
    keys.push_back(jittered(g, next));
    frame = next;
  }

  const double wrist_phase[3] = {random.uniform(0, 2 * M_PI), random.uniform(0, 2 * M_PI),
                                 random.uniform(0, 2 * M_PI)};
  const std::vector<SynthPose> shapes = make_rom_poses(rig, num_frames, seed);
  std::vector<SynthPose> poses(num_frames);
  if (gesture_names) gesture_names->assign(num_frames, "");
  size_t segment = 0;
  for (int k = 0; k < num_frames; ++k) {
    while (segment + 2 < keys.size() && keys[segment + 1].frame <= k) ++segment;
    const Key& a = keys[segment];
    const Key& b = keys[std::min(segment + 1, keys.size() - 1)];
    const double span = std::max(1e-9, b.frame - a.frame);
    // Finger-wise progress: each finger (and the thumb, index 0) starts up to kMaxLag late.
    auto progress = [&](int finger) {
      const double lag = std::min(b.lag[finger], 0.5 * span);
      return ease((k - a.frame - lag) / std::max(1e-9, span - lag));
    };
    Gesture now;
    double spread_progress = 0;
    for (int f = 0; f < 4; ++f) {
      const double p = progress(f + 1);
      spread_progress += p / 4;
      for (int j = 0; j < 3; ++j)
        now.fingers[f][j] = a.fingers[f][j] + p * (b.fingers[f][j] - a.fingers[f][j]);
    }
    now.spread = a.spread + spread_progress * (b.spread - a.spread);
    const double pt = progress(0);
    now.opposition = a.opposition + pt * (b.opposition - a.opposition);
    now.thumb_flex = a.thumb_flex + pt * (b.thumb_flex - a.thumb_flex);
    HandArticulation art = gesture_articulation(now);
    const double t = 2 * M_PI * k / 40.0;  // one slow wrist cycle per ~8 s
    art.pronation = WristAmplitudes::pronation * std::sin(0.9 * t + wrist_phase[0]);
    art.wrist_flex = WristAmplitudes::flexion * std::sin(1.3 * t + wrist_phase[1]);
    art.wrist_deviation = WristAmplitudes::deviation * std::sin(1.7 * t + wrist_phase[2]);

    SynthPose& pose = poses[k];
    pose.articulation = art;
    pose.pose = articulate(axes, art);
    pose.shape = shapes[k].shape;
    if (gesture_names) (*gesture_names)[k] = vocabulary[b.gesture].name;
  }
  return poses;
}

}  // namespace handscs
