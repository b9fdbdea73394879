// One training capture read from an InterHand2.6M-layout folder: the usable frames with cameras and
// MANO parameters, the train/test split, and lazily decoded ROI crops with hand masks (LRU-cached).
//
// Typical use (trainer):
//   Capture capture = Capture::open(config.data, run_dir + "/cache");
//   for (const FrameInfo& f : capture.train()) ...              // cameras, pose, shape, trans
//   capture.prefetch({next indices});                           // background decode
//   FrameSample s = capture.load(capture.train()[k]);           // ROI crop + mask as uint8 tensors
//   render with s.roi_camera() (or the full camera plus s.roi), compare against s.image / s.mask.
//
// Masks: the posed rig mesh (rig + the frame's MANO parameters, lbs()) rasterised into the view
// (data/mesh_raster.h), refined against the image (data/mask_refine.h), cached as PNG files under
// <mask_cache_dir>/masks-<settings hash>/ with the image's relative path. ROI: mask bounding box
// plus roi_margin. Units: metres; cameras as core/camera.h.
#pragma once

#include <torch/types.h>

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <opencv2/core/mat.hpp>
#include <set>
#include <string>
#include <vector>

#include "core/camera.h"
#include "data/camera_transforms.h"
#include "data/capture_config.h"
#include "data/crop_cache.h"
#include "hand/rig.h"

namespace handscs {

// One hand's annotated parameters in a frame (data.hand both: FrameInfo::hands).
struct HandParams {
  std::array<float, 48> pose{};    // as FrameInfo::pose
  std::array<float, 10> shape{};
  std::array<float, 3> trans{};    // metres
  std::array<float, 63> joints{};  // MANO21 order, metres (zeros, joint_valid 0, when none)
  std::array<uint8_t, 21> joint_valid{};
};

// One usable image: where it is, its camera, and the hand's annotated pose.
struct FrameInfo {
  int64_t index = 0;       // position in Capture::frames()
  int64_t image_id = 0;    // data.json images[].id
  std::string image_path;  // path of the JPEG
  std::string file_name;   // relative to the images folder (InterHand2.6M: images/{split}/, as in
                           // data.json; the other layouts: images/, "<camera>/<frame>.jpg")
  std::string mask_path;   // mask supplied with the capture ("" = rasterised from the posed mesh)
  std::string camera_id;   // "400026"
  std::string seq_name;
  int capture = 0;
  int64_t frame_idx = 0;
  int pose_index = 0;           // frames with the same frame_idx share a pose: Capture::num_poses()
  bool held_out = false;        // novel_pose: this pose is one of the held-out (test) poses
  Camera camera;                // full image, metres
  std::array<float, 4> bbox{};  // data.json bbox [x, y, w, h] (pixels)
  std::array<float, 48> pose{};  // axis-angle as annotated (relative to hands_mean unless
                                 // config.flat_hand_mean)
  std::array<float, 10> shape{};
  std::array<float, 3> trans{};    // metres
  std::array<float, 63> joints{};  // annotated joints, MANO21 order, metres, row-major [21, 3]
                                   // (zeros, joint_valid 0, when the capture has none)
  std::array<uint8_t, 21> joint_valid{};  // MANO21 order
  // data.hand both: each hand's parameters, indexed by Handedness (right, left); a hand the frame
  // has no usable parameters for is absent. The fields above then hold the first present hand's.
  // Empty with one hand.
  std::array<std::optional<HandParams>, 2> hands;
  // data.hand both: the hand's parameters, null when the frame lacks it.
  const HandParams* hand(Handedness side) const {
    const auto& h = hands[side == Handedness::right ? 0 : 1];
    return h ? &*h : nullptr;
  }
};

// The frame as hand `side` sees it: a copy whose pose, shape, trans and joints are that hand's
// (data.hand both), so that one-hand code reads them where it always has. A frame without `hands`
// (one hand) is returned as it is.
FrameInfo frame_of_hand(const FrameInfo& frame, Handedness side);

// A one-hand frame's own hand fields (pose, shape, trans, joints) as one HandParams.
HandParams own_hand(const FrameInfo& frame);

// A decoded frame: image and mask as uint8 tensors, cropped to the ROI unless full_image.
struct FrameSample {
  int64_t index = 0;    // FrameInfo::index
  Camera camera;        // full-image camera
  PixelRect roi;        // rectangle of `image` in full-image pixels (the whole image if full)
  torch::Tensor image;  // [h, w, 3] uint8 RGB (a copy: safe to modify)
  torch::Tensor mask;   // [h, w] uint8, 1 = hand, 0 = background
  // Camera of the crop itself (principal point shifted by the ROI origin).
  Camera roi_camera() const { return crop_camera(camera, roi); }
};

// Why an image was left out, with the image path.
struct SkippedImage {
  std::string path;
  std::string reason;  // "null MANO", "no joint_3d entry", "other hand", "interacting",
                       // "missing image", "not a file", "damaged JPEG", "oversized image",
                       // "unreadable image", "wrong image size", "black image", "hand outside
                       // image", "poor joint fit"
};

// The rig of hand `side`, one of config.hand's, that the capture poses for its masks and the
// trainer builds that hand's avatar on: "builtin" and "builtin+fingers" are that built-in hand of
// that side; a rig file is used for its own hand and mirrored for the other (data.hand both).
// Throws Error naming <config_key>.rig when one hand is selected and the file's rig is of the
// other, and for builtin+fingers on a synthetic capture (its betas 7-9 were never shown).
Rig capture_rig(const CaptureConfig& config, Handedness side, const std::string& config_key = "data");

// novel_view camera choice when the config names none: n = min(train + test, available) cameras
// evenly spaced over the sorted ids; test views are spread among them in proportion (Bresenham),
// so each test view sits between training views. Each side gets at least one camera.
void choose_novel_view_cameras(const std::set<std::string>& available, int train_views,
                               int test_views, std::set<std::string>& train,
                               std::set<std::string>& test);

class Capture {
 public:
  // Reads the annotations, selects and checks frames (skips are logged as one summary line), poses
  // the rig for every pose and splits train/test. mask_cache_dir: where masks are cached on disk
  // ("" = no disk cache). Throws Error naming the file and key for bad annotations or config;
  // config_key is where the config sits in the user's file ("data" in a run config, "capture" in a
  // POSES file), so messages name keys as written there.
  static Capture open(const CaptureConfig& config, const std::string& mask_cache_dir = "",
                      const std::string& config_key = "data");

  Capture(Capture&&) noexcept;
  Capture& operator=(Capture&&) noexcept;
  ~Capture();

  const CaptureConfig& config() const;
  // The layout read (data/capture_layout.h): interhand, handscs or easymocap.
  CaptureConfig::Layout layout() const;
  // Folder of the region masks of this capture's images under a regions folder: <split>/ for
  // InterHand2.6M (regions/test/Capture0/...), none for the other layouts (regions/<camera>/...).
  std::string region_subfolder() const;
  const std::vector<FrameInfo>& frames() const;  // every usable frame (train and test)
  const std::vector<FrameInfo>& train() const;   // training frames (copies with FrameInfo::index)
  const std::vector<FrameInfo>& test() const;    // held-out frames
  int num_poses() const;
  std::vector<std::string> cameras() const;             // camera ids kept, sorted
  std::vector<std::string> monochrome_cameras() const;  // detected (dropped if drop_monochrome)
  // Grey images (R = G = B) of cameras that record colour: used, and warned about at open.
  const std::vector<std::string>& grey_images() const;
  const std::vector<SkippedImage>& skipped() const;
  // "<data.json>: skipped N of M images (null MANO a, black image b): path, path, ..." or "".
  const std::string& skip_summary() const;

  // Decoded ROI crop (or full image) of a frame, from the cache or decoded now.
  FrameSample load(const FrameInfo& frame, bool full_image = false);
  // Queues frames for the background loader, replacing what was still queued.
  void prefetch(const std::vector<int64_t>& indices, bool full_image = false);

  // Uncached building blocks (benchmarks, tests): full BGR image; mask [H, W] 0/1 (mesh + refine).
  cv::Mat decode_image(const FrameInfo& frame) const;
  cv::Mat compute_mask(const FrameInfo& frame, const cv::Mat& bgr) const;
  // Posed rig vertices [V, 3] (world, m) of a pose and the rig's faces [F, 3]. data.hand both: the
  // pose's hands one after the other (right first; V is a multiple of the one hand's count) and
  // the faces of two hands; a pose with one hand uses the first half of the faces (the hands share
  // a topology).
  const std::vector<float>& posed_vertices(int pose_index) const;
  const std::vector<int64_t>& faces() const;
  // Faces [F, 3] of the mesh posed_vertices(pose_index) holds (a prefix of faces()).
  int64_t num_faces(int pose_index) const;

  const CropCache& cache() const;
  std::string mask_cache_folder() const;  // "" when masks are not cached on disk

 private:
  struct Impl;
  explicit Capture(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace handscs
