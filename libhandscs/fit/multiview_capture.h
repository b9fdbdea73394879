// A multi-view capture of one instant with per-view 2D hand landmarks, in the layout NeuS, IDR and
// FMHR share (data/neus_cameras.h: the camera archive, images and masks), with
//   <root>/pose/NN.json    MediaPipe landmarks per view: {"Left": [63], "Right": [63]}, x and y
//                          normalised to [-1, 1] over the image, [] where not detected
// The landmarks, continuous coordinates over the image, need no pixel-centre shift.
#pragma once

#include <string>
#include <vector>

#include "core/camera.h"
#include "fit/multiview_hands.h"

namespace handscs {

struct MultiviewCapture {
  std::string root;
  std::vector<std::string> views;        // view names ("00", "01", ...), in index order
  std::vector<Camera> cameras;           // the project's convention
  std::vector<std::string> images, masks;  // paths ("" where absent)
  std::vector<Detection> detections;     // every view's landmarks, MANO21 order
};

MultiviewCapture read_multiview_capture(const std::string& root);

}  // namespace handscs
