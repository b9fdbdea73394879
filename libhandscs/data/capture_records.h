// What a capture layout's reader hands to Capture::open, whatever its files look like: the images
// (with their camera, frame and optional mask), the cameras (metres, core/camera.h's pixel-centre
// convention, lens distortion apart), and each frame's MANO parameters and joints per hand.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "core/camera.h"
#include "data/capture_config.h"
#include "data/interhand_annotations.h"  // ManoParams
#include "data/lens_distortion.h"

namespace handscs {

// One image of one camera at one frame.
struct RecordImage {
  int64_t id = 0;          // unique within the capture
  std::string file_name;   // relative to CaptureRecords::images_dir
  std::string mask_path;   // a mask supplied with the capture ("" = rasterise the posed mesh)
  int width = 0, height = 0;
  int capture = 0;         // InterHand2.6M's capture number (0 in the other layouts)
  std::string seq_name;    // sequence label ("" when the layout has none)
  std::string camera;      // camera name, a key of CaptureRecords::cameras
  int64_t frame_idx = 0;   // frame number: images with the same one share a pose
  std::array<double, 4> bbox{};  // [x, y, w, h] pixels when the layout has one, else zeros
  std::string hand_type;   // "right", "left", "interacting" or "" (not stated)
};

// One camera: intrinsics and extrinsics (width and height are the image's), lens distortion.
struct RecordCamera {
  Camera camera;
  LensDistortion distortion;
  std::string where;  // names the camera in errors: "<file>: <key path>"
};

// One hand of one frame: joints in MANO21 order, metres, world frame.
struct RecordHand {
  ManoParams mano;
  bool has_joints = false;
  std::array<double, 63> joints{};
  std::array<uint8_t, 21> joint_valid{};
  std::string fit_problem;  // pose fitted to the joints: why it is not used ("" when it is)
};

// One frame: a hand without parameters is absent.
struct RecordFrame {
  std::optional<RecordHand> right, left;
  bool has_joint_entry = true;  // InterHand2.6M: false when joint_3d.json has no entry
};

struct CaptureRecords {
  CaptureConfig::Layout layout = CaptureConfig::Layout::interhand;  // never automatic
  std::string images_dir;   // folder RecordImage::file_name is relative to
  std::string index_file;   // file that lists the images (named in skip summaries and errors)
  std::string scope;        // the selection in messages: "capture 3 of <data.json>" or the index
  // Files whose size and time stand for the annotations' content (the mask cache's key); the first
  // is also named by path.
  std::vector<std::string> source_files;
  std::vector<RecordImage> images;  // in the index's order
  std::map<std::string, RecordCamera> cameras;
  std::map<int64_t, RecordFrame> frames;
};

}  // namespace handscs
