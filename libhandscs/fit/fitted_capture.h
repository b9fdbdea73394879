// A capture given its hands by the keypoint fit: `handscs-fit --keypoints K --capture-dir C` reads
// C, a capture in the project's or EasyMocap's layout (docs/CAPTURE_FORMAT.md) whose frames may
// carry no hands, matches the keypoint file's frames to C's by frame number, and writes a capture in
// the same layout whose hands are the fitted ones, with C's images, masks and regions linked.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "data/capture_config.h"

namespace handscs {

struct FittedCaptureSource {
  std::string root;                  // the capture folder
  CaptureConfig::Layout layout;      // handscs or easymocap
  nlohmann::json cameras;            // capture.json's "cameras" (handscs layout), as written
  struct Frame {
    int64_t frame = 0;
    std::string sequence;            // "" when not stated
  };
  std::vector<Frame> frames;         // in capture.json's order
  std::set<int64_t> numbers;         // their frame numbers
  // What the written capture links to: images, masks, regions and EasyMocap's calibration, each
  // the source's entry of that name, resolved.
  std::vector<std::pair<std::string, std::string>> links;
};

// Reads and checks the capture at `root` as the training reader would (cameras, image folders,
// frames) and resolves what will be linked; refuses any other layout by name, a link that leads
// nowhere, and a capture inside `out` (the folder the fit replaces).
FittedCaptureSource read_fitted_capture_source(const std::string& root, const std::string& out);

// The capture's frame number a keypoint frame's name gives ("000042" or "42"); an error naming
// `keypoint_file` when the name is not a frame number of `source`.
int64_t capture_frame_of(const std::string& name, const FittedCaptureSource& source,
                         const std::string& keypoint_file);

// Writes the capture into `out`: capture.json with `hands` (per frame number, right and left;
// null where not fitted) and links to the source's images, masks, regions and, for EasyMocap,
// its calibration files. A frame without keypoints is written without hands.
void write_fitted_capture(const FittedCaptureSource& source, const std::string& out, bool flat_hand_mean,
                          const std::map<int64_t, std::array<nlohmann::json, 2>>& hands);

}  // namespace handscs
