// Where an InterHand2.6M-layout capture keeps its files: images/{split}/ (optionally under
// InterHand2.6M_5fps_batch1/) and annotations/{split}/InterHand2.6M_{split}_{kind}.json.
#pragma once

#include <string>

namespace handscs {

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
