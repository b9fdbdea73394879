// The camera archive of the layout NeuS, IDR and FMHR share, and the views it numbers:
//   <root>/camera/param.npz | cameras.npz | cameras_sphere.npz   per view i: world_mat_i (K [R | t],
//        3x4 or 4x4, any scale) and/or int_i and ext_i (4x4 intrinsics, world-to-camera [R | t])
//   <root>/img/NN.png | image/NNN.png (or .jpg)                 the views' images
//   <root>/mask/NN.png                                          optional masks (255 = hand)
// or, for several instants sharing the cameras, the images and masks in <root>/<frame>/img/, mask/.
// scale_mat_i is not read: world_mat_i alone projects world points (metres in FMHR's archives).
// OpenCV's K centres pixels on integers: cx and cy gain 0.5 for the project's convention
// (docs/CAPTURE_FORMAT.md).
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "core/camera.h"

namespace handscs {

// One view of the archive that has an image.
struct NeusView {
  int index = 0;            // i of world_mat_i
  std::string name;         // i with two digits at least ("00", "07", "15", "123")
  Camera camera;            // the project's convention; width and height of this view's image
  std::string where;        // names the camera in errors: "<archive>: world_mat_<i>"
  std::string image, mask;  // paths (mask "" when the view has none)
};

struct NeusViews {
  std::string archive;          // path of the camera archive
  std::string image_dir;        // folder of the images
  std::vector<NeusView> views;  // in index order; a camera without an image is left out (warned)
};

// The camera archive under `root` ("" when it holds none of the names above).
std::string find_neus_camera_archive(const std::string& root);

// The image folder of `dir` (img/, image/ or images/; "" when it holds none).
std::string find_neus_image_folder(const std::string& dir);

// "<dir>/NN<extension>", "<dir>/NNN<extension>" or "<dir>/NNNNNN<extension>" for view i, whichever
// exists ("" when none does or dir is "").
std::string neus_view_file(const std::string& dir, int i, const std::string& extension);

// The views of `root`, their images and masks from `frame_dir` (a folder holding img/ and mask/;
// "" = root itself). Throws Error naming the archive and key for a camera that does not
// decompose into a plausible pinhole camera (singular, skewed, non-finite, implausible for its
// image's size), world_mat_i and int_i/ext_i that disagree, an image numbered without a camera,
// or no view with an image. A camera whose image is missing is skipped with a warning naming it.
NeusViews read_neus_views(const std::string& root, const std::string& frame_dir = "");

// The instants of `root` and their folders: {0, root} when root holds img/ or image/, else each
// sub-folder named by a number ("3", "000003") that holds one, by that number. Throws Error when
// there is neither, or when two folders name one frame.
std::map<int64_t, std::string> neus_frame_folders(const std::string& root);

// K, R, t of a 3x4 projection P = s K [R | t] (row-major), by RQ decomposition of its left 3x3:
// K upper triangular with positive diagonal and K[2][2] = 1, R a rotation. Throws Error naming
// `where` when P does not decompose into a camera (rank-deficient left block).
Camera camera_from_projection(const double* P, int width, int height, const std::string& where);

}  // namespace handscs
