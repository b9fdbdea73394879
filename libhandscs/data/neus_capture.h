// Reader of the layout NeuS, IDR and FMHR share (docs/CAPTURE_FORMAT.md): the cameras, images and
// masks of data/neus_cameras.h, one instant (frame 0) or one folder per instant (<root>/<frame>/img/,
// sharing the root's cameras), and the hands' MANO parameters from data.hands_file (capture.json's
// "frames", e.g. the capture.json handscs-fit --multiview writes).
// Camera ids are "view" and the view's number ("view00"), as handscs-fit's capture.json names them.
#pragma once

#include <string>

#include "data/capture_records.h"

namespace handscs {

// Reads c.root in layout neus; `prefix` names the config section in errors ("data").
// Throws Error naming the file and key for a missing or bad hands file, a frame without images, and a
// hand that lies behind a camera (a world_mat_i with a negative focal length or a flipped sign).
CaptureRecords read_neus_capture(const CaptureConfig& c, const std::string& prefix);

}  // namespace handscs
