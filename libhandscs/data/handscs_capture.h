// Reader of the project's own capture layout (docs/CAPTURE_FORMAT.md): capture.json (format
// "handscs-capture", version 1) with the cameras and each frame's MANO parameters per hand,
// images/<camera>/<frame>.jpg (or .png), optional masks/<camera>/<frame>.png. The EasyMocap layout
// is the same without capture.json's cameras: they come from intri.yml and extri.yml.
// Every problem is an Error naming the file, the key and what is wrong.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "data/capture_records.h"
#include "data/json_view.h"

namespace handscs {

constexpr char kHandscsCaptureFormat[] = "handscs-capture";
constexpr int kHandscsCaptureVersion = 1;

// "000042": the file stem of frame 42's images and masks (six digits, as EasyMocap names them;
// longer numbers are written in full).
std::string frame_file_stem(int64_t frame);

// capture.json's format, version and flat_hand_mean, each checked when present (all three must be
// when `required`); flat_hand_mean must equal the config's, named `flat_key` in the error.
void check_capture_header(const JsonView& top, bool required, bool flat_hand_mean,
                          const std::string& flat_key);

// One entry of capture.json's "frames": the frame number, its hands, its sequence and hand_type.
struct CaptureFrameEntry {
  int64_t frame = 0;
  RecordFrame record;
  std::string sequence, hand_type;  // "" when not stated
};

// Every entry of a "frames" array (not empty, no frame twice), checked key by key.
std::vector<CaptureFrameEntry> read_capture_frames(const JsonView& frames);

// Reads `root` in layout handscs or easymocap. `flat_hand_mean` is the config's value, which
// the file's must equal; `flat_key` names it in the error ("data.flat_hand_mean").
CaptureRecords read_handscs_capture(const std::string& root, CaptureConfig::Layout layout,
                                    bool flat_hand_mean, const std::string& flat_key);

}  // namespace handscs
