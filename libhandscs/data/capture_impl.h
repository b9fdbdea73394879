// Private state of data/capture.h shared by capture.cpp (opening, selection, split) and
// capture_loader.cpp (decoding, masks, cache, prefetch threads). Not part of the public API.
#pragma once

#include <condition_variable>
#include <deque>
#include <exception>
#include <map>
#include <mutex>
#include <set>
#include <thread>

#include "data/capture.h"
#include "data/lens_distortion.h"

namespace handscs {

// A supplied mask and the posed meshes' overlap at least this much (intersection over union) where
// masks and poses agree: FMHR's 13 good masks reach 0.42-0.67 against its fitted hands (meshes
// without forearms, fitted 11 px off at the median), its three broken ones (a dotted sliver of
// the hand) 0.03-0.15.
constexpr double kMinSuppliedMaskIou = 0.3;

struct Capture::Impl {
  CaptureConfig config;
  CaptureConfig::Layout layout = CaptureConfig::Layout::interhand;  // as read (never automatic)
  std::vector<FrameInfo> frames, train, test;
  int num_poses = 0;
  std::vector<std::vector<float>> posed_vertices;  // [pose][V * 3] (Capture::posed_vertices)
  std::vector<int64_t> faces;                      // [F * 3] (Capture::faces)
  int64_t num_vertices = 0;                        // of one hand
  int64_t faces_per_hand = 0;
  // Faces of the mesh posed_vertices[pose] holds: one hand's per hand present.
  int64_t num_faces(int pose) const {
    return faces_per_hand * static_cast<int64_t>(posed_vertices.at(pose).size() / 3 / num_vertices);
  }
  std::vector<std::string> cameras, monochrome_cameras;
  std::vector<std::string> grey_images;  // grey images of colour cameras (Capture::grey_images)
  std::vector<SkippedImage> skipped;
  std::string skip_summary;
  std::string mask_folder;  // "" = no disk cache
  std::map<std::string, UndistortMaps> undistort;  // cameras with lens distortion, by name
  std::string undistorted_folder;  // undistorted images' disk cache ("" = none)

  explicit Impl(size_t budget_bytes) : cache(budget_bytes) {}
  ~Impl() { stop_workers(); }

  // Loader (capture_loader.cpp).
  CropCache cache;
  std::mutex mutex;                 // guards queue, in_flight, errors, stopping
  std::condition_variable work_cv;  // queue filled or stopping
  std::condition_variable done_cv;  // an in-flight load finished
  std::deque<uint64_t> queue;
  std::set<uint64_t> in_flight;
  std::map<uint64_t, std::exception_ptr> errors;  // prefetch failures, rethrown by load
  bool stopping = false;
  std::vector<std::thread> workers;

  static uint64_t key(int64_t index, bool full) { return static_cast<uint64_t>(index) * 2 + full; }
  void start_workers(int count);
  void stop_workers();
  void worker_loop();
  std::shared_ptr<const CachedCrop> produce(int64_t index, bool full) const;
  std::shared_ptr<const CachedCrop> get(int64_t index, bool full);
  cv::Mat decode(const FrameInfo& frame) const;
  cv::Mat read_image(const std::string& path, const FrameInfo& frame) const;
  cv::Mat undistorted(const FrameInfo& frame, const UndistortMaps& maps) const;
  cv::Mat mask_for(const FrameInfo& frame, const cv::Mat& bgr) const;
  cv::Mat compute_mask(const FrameInfo& frame, const cv::Mat& bgr) const;
  cv::Mat posed_mesh_mask(const FrameInfo& frame) const;  // 0/1, unrefined
  // Checks each supplied mask once and returns whether it agrees with the posed meshes' mask (IoU
  // of at least kMinSuppliedMaskIou); warns, once, when it does not.
  bool check_supplied_mask(const FrameInfo& frame, const cv::Mat& mask) const;
  mutable std::mutex mask_checked_mutex;             // guards mask_checked
  mutable std::map<std::string, bool> mask_checked;  // supplied mask -> it agrees
};

}  // namespace handscs
