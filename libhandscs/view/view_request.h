// What the viewer's page asks for, as a JSON request body: a hand pose from one of three sources,
// an orbit view, and an image format:
//   {"controls": {"index.mcp": 0.5, ...}            (view/hand_controls.h; the first hand's)
//    | "controls": {"right": {...}, "left": {...}}   (a two-hand avatar: each hand's; either may be
//                                                     left out, and that hand keeps its captured pose)
//    | "held_out": i                                 (the run capture's i-th held-out pose)
//    | "pose": {"pose": [48], "shape": [10], "trans": [3]},   (a POSES entry, infer/pose_source.h)
//    "view": {"yaw", "pitch", "distance", "width", "height"}, (view/orbit_view.h; defaults fill in)
//    "format": "jpeg" | "png", "quality": 50..100}   (JPEG quality)
// Every value is checked; an error names the key ("request: view.width: 9000 px is outside ...").
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>

#include "infer/pose_source.h"
#include "view/hand_controls.h"
#include "view/orbit_view.h"

namespace handscs {

// Largest request body read (bytes): a full pose request is ~1.5 KB of JSON.
constexpr size_t kMaxViewRequestBytes = 16 * 1024;
// JPEG qualities accepted: below 50 blocks show while dragging; 100 is the encoder's maximum.
constexpr int kMinJpegQuality = 50, kMaxJpegQuality = 100;

enum class ImageFormat { jpeg, png };

struct ViewRequest {
  enum class Source { controls, held_out, pose };
  Source source = Source::controls;
  HandControls controls;     // Source::controls: the first hand's (the only one's)
  // Source::controls given hand by hand ("right"/"left"), by Handedness; all empty for the form above.
  std::array<std::optional<HandControls>, 2> hand_controls;
  int64_t held_out = 0;      // Source::held_out: index into the run capture's held-out poses
  PoseFrame pose;            // Source::pose
  OrbitView view;
  ImageFormat format = ImageFormat::jpeg;
  int quality = 90;          // JPEG quality: 90 keeps the browser's image within ~1 dB of PNG's
};

// Parses and checks a request body; `default_view` fills the view keys not given. Throws Error.
ViewRequest parse_view_request(const std::string& body, const OrbitView& default_view);

}  // namespace handscs
