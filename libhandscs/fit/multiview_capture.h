// A multi-view capture with per-view 2D hand landmarks, in the layout NeuS, IDR and FMHR share
// (data/neus_cameras.h: the camera archive, images and masks), with
//   <root>/pose/NN.json    MediaPipe landmarks per view: {"Left": [63], "Right": [63]}, x and y
//                          normalised to [-1, 1] over the image, [] where not detected
// for one instant, or for a sequence the same in a folder per instant beside the archive:
//   <root>/<frame>/img/NN.png, <root>/<frame>/mask/NN.png, <root>/<frame>/pose/NN.json
// The landmarks, continuous coordinates over the image, need no pixel-centre shift.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/camera.h"
#include "fit/multiview_hands.h"

namespace handscs {

// One instant: its images, masks and landmarks, by view (the capture's views, in their order).
struct MultiviewInstant {
  int64_t frame = 0;                       // 0 for a capture of one instant, else its folder's number
  std::vector<std::string> images, masks;  // paths by view ("" where absent)
  std::vector<Detection> detections;       // every view's landmarks, MANO21 order
};

struct MultiviewCapture {
  std::string root;
  bool sequence = false;                 // frame folders rather than one instant at the root
  std::vector<std::string> views;        // view names ("00", "01", ...), in index order
  std::vector<Camera> cameras;           // the project's convention
  std::vector<MultiviewInstant> instants;  // by frame number; only instants with landmarks
};

// Throws Error naming the file for a malformed landmark file, and for a capture with no landmarks
// at all. In a sequence, an instant without landmarks is left out with a warning; its views must
// have the sizes they have in the first instant holding them (one camera per view).
MultiviewCapture read_multiview_capture(const std::string& root);

}  // namespace handscs
