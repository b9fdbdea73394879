// Which layout a capture folder has (docs/CAPTURE_FORMAT.md), and where an InterHand2.6M-layout
// capture keeps its files: images/{split}/ (optionally under InterHand2.6M_5fps_batch1/) and
// annotations/{split}/InterHand2.6M_{split}_{kind}.json.
#pragma once

#include <string>

#include "data/capture_config.h"

namespace handscs {

// The file that marks the project's own layout, and the two that mark EasyMocap's (with it).
constexpr char kHandscsCaptureFile[] = "capture.json";
constexpr char kEasyMocapIntrinsicsFile[] = "intri.yml";
constexpr char kEasyMocapExtrinsicsFile[] = "extri.yml";
// The generator's settings, which handscs-synth writes beside every synthetic capture's layout.
constexpr char kSynthSettingsFile[] = "synth.json";

// The layout of `root`: `setting` as given, or for automatic easymocap when root holds intri.yml,
// else handscs when it holds capture.json, else neus when it holds a NeuS/IDR camera archive
// (data/neus_cameras.h), else interhand (never automatic).
// Throws Error naming root_key for an empty or missing root.
CaptureConfig::Layout detect_capture_layout(const std::string& root, CaptureConfig::Layout setting,
                                            const std::string& root_key = "data.root");

struct CaptureLayout {
  std::string images_dir;  // folder that data.json's file_name values are relative to
  std::string data_json, camera_json, joint_3d_json, mano_json;
};

// Finds the image and annotation folders under `root` for `split`; throws Error naming the root and
// the folders looked for when either is missing.
// root_key names the root in errors as the user wrote it (e.g. "data.root").
CaptureLayout resolve_capture_layout(const std::string& root, const std::string& split,
                                     const std::string& root_key = "data.root");

}  // namespace handscs
