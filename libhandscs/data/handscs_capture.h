// Reader of the project's own capture layout (docs/CAPTURE_FORMAT.md): capture.json (format
// "handscs-capture", version 1) with the cameras and each frame's MANO parameters per hand,
// images/<camera>/<frame>.jpg (or .png), optional masks/<camera>/<frame>.png. The EasyMocap layout
// is the same without capture.json's cameras: they come from intri.yml and extri.yml.
// Every problem is an Error naming the file, the key and what is wrong.
#pragma once

#include <cstdint>
#include <string>

#include "data/capture_records.h"

namespace handscs {

constexpr char kHandscsCaptureFormat[] = "handscs-capture";
constexpr int kHandscsCaptureVersion = 1;

// "000042": the file stem of frame 42's images and masks (six digits, as EasyMocap names them;
// longer numbers are written in full).
std::string frame_file_stem(int64_t frame);

// Reads `root` in layout handscs or easymocap. `flat_hand_mean` is the config's value, which
// the file's must equal; `flat_key` names it in the error ("data.flat_hand_mean").
CaptureRecords read_handscs_capture(const std::string& root, CaptureConfig::Layout layout,
                                    bool flat_hand_mean, const std::string& flat_key);

}  // namespace handscs
