// A multi-view capture of one instant with per-view 2D hand landmarks, in the layout NeuS, IDR and
// FMHR share: a numpy camera archive and files numbered by view.
//   <root>/camera/param.npz | cameras.npz | cameras_sphere.npz   per view i: int_i and ext_i (4x4,
//        intrinsics and world-to-camera [R | t]) or world_mat_i (K [R | t], 3x4 or 4x4)
//   <root>/img/NN.png | image/NNN.png                            the views' images
//   <root>/mask/NN.png                                           optional masks
//   <root>/pose/NN.json    MediaPipe landmarks per view: {"Left": [63], "Right": [63]}, x and y
//                          normalised to [-1, 1] over the image, [] where not detected
// Units are the archive's (metres in FMHR's). OpenCV's K centres pixels on integers: cx and cy
// gain 0.5 for the project's convention (docs/CAPTURE_FORMAT.md); the landmarks, continuous
// coordinates over the image, need no shift.
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

// K, R, t of a 3x4 projection P = s K [R | t] (row-major), by RQ decomposition of its left 3x3:
// K upper triangular with positive diagonal and K[2][2] = 1, R a rotation. Throws Error naming
// `where` when P does not decompose into a camera (rank-deficient left block).
Camera camera_from_projection(const double* P, int width, int height, const std::string& where);

}  // namespace handscs
