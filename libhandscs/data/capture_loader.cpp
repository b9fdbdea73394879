// Capture's image side: decode, mask (disk cache or mesh + refinement), ROI crop, LRU cache, and
// the background prefetch threads.
#include <unistd.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <spdlog/spdlog.h>

#include "core/atomic_file.h"  // ensure_directory
#include "core/error.h"
#include "core/image_header.h"  // read_image_bytes
#include "core/png_damage.h"
#include "data/capture_impl.h"
#include "data/mask_refine.h"
#include "data/mesh_mask.h"
#include "data/roi.h"
#include "io/image_file.h"

namespace handscs {

namespace fs = std::filesystem;

namespace {

// Writes a cache file via a temporary and a rename, without fsync: a cache entry needs no
// durability (a missing or torn file is recomputed), and fsync per mask would cost milliseconds.
void write_cache_file(const fs::path& path, const std::vector<uint8_t>& bytes) {
  const fs::path temp = path.string() + ".tmp." + std::to_string(::getpid()) + "." +
                        std::to_string(std::hash<std::thread::id>{}(std::this_thread::get_id()));
  {
    std::ofstream out(temp, std::ios::binary);
    out.write(reinterpret_cast<const char*>(bytes.data()),
              static_cast<std::streamsize>(bytes.size()));
    if (!out) throw Error(path.string() + ": cannot write cache file");
  }
  std::error_code ec;
  fs::rename(temp, path, ec);
  if (ec) {
    fs::remove(temp, ec);
    throw Error(path.string() + ": cannot write cache file");
  }
}

// A cached image or mask this project wrote, or an empty Mat when it cannot be read or decoded
// (damaged, cut short, replaced by something else): the caller then makes it again and overwrites it.
cv::Mat read_cached(const fs::path& file, int flags) {
  try {
    return decode_image_file(file.string(), flags);
  } catch (const Error&) {
    return cv::Mat();
  }
}

// Failed prefetches remembered for load() to rethrow; beyond this many the oldest are dropped
// (load() then simply retries and throws itself).
constexpr size_t kMaxRememberedErrors = 256;
}  // namespace

cv::Mat Capture::Impl::read_image(const std::string& path, const FrameInfo& frame) const {
  // Read again through a checked descriptor: the open's scan read each image, but a file replaced
  // since by a named pipe would block a decode by path forever.
  const cv::Mat bgr = decode_image_file(path, cv::IMREAD_COLOR);
  if (bgr.empty()) throw Error(path + ": cannot decode image");
  if (bgr.cols != frame.camera.width || bgr.rows != frame.camera.height)
    throw Error(path + ": image is " + std::to_string(bgr.cols) + "x" + std::to_string(bgr.rows) +
                " but " + (layout == CaptureConfig::Layout::interhand ? "data.json" : "its camera") + " says " +
                std::to_string(frame.camera.width) + "x" + std::to_string(frame.camera.height));
  return bgr;
}

cv::Mat Capture::Impl::undistorted(const FrameInfo& frame, const UndistortMaps& maps) const {
  fs::path file;
  if (!undistorted_folder.empty()) {
    file = fs::path(undistorted_folder) / fs::path(frame.file_name).replace_extension(".png");
    if (std::error_code ec; fs::is_regular_file(file, ec)) {
      cv::Mat stored = read_cached(file, cv::IMREAD_COLOR);
      if (stored.cols == frame.camera.width && stored.rows == frame.camera.height) return stored;
      // Unreadable or stale: undistort again and overwrite below.
    }
  }
  cv::Mat bgr = undistort_image(read_image(frame.image_path, frame), maps);
  if (!file.empty()) {
    std::vector<uint8_t> png;  // lossless: a cached image equals a freshly undistorted one
    cv::imencode(".png", bgr, png);
    ensure_directory(file.parent_path().string());
    write_cache_file(file, png);
  }
  return bgr;
}

cv::Mat Capture::Impl::decode(const FrameInfo& frame) const {
  auto maps = undistort.find(frame.camera_id);
  if (maps == undistort.end()) return read_image(frame.image_path, frame);
  return undistorted(frame, maps->second);
}

cv::Mat Capture::Impl::posed_mesh_mask(const FrameInfo& frame) const {
  const std::vector<float>& vertices = posed_vertices.at(frame.pose_index);
  return mesh_mask(vertices.data(), static_cast<int64_t>(vertices.size() / 3), faces.data(),
                   num_faces(frame.pose_index), frame.camera);
}

bool Capture::Impl::check_supplied_mask(const FrameInfo& frame, const cv::Mat& mask) const {
  {
    // Once per mask: a crop loaded again (cache eviction, full image) does not rasterise again.
    std::lock_guard<std::mutex> lock(mask_checked_mutex);
    const auto found = mask_checked.find(frame.mask_path);
    if (found != mask_checked.end()) return found->second;
  }
  const cv::Mat mesh = posed_mesh_mask(frame);
  const double both = cv::countNonZero(mask & mesh);
  const double either = cv::countNonZero(mask | mesh);
  const double iou = either > 0 ? both / either : 1.0;
  spdlog::debug("{}: IoU {:.3f} with the posed hands", frame.mask_path, iou);
  const bool agrees = iou >= kMinSuppliedMaskIou;
  {
    std::lock_guard<std::mutex> lock(mask_checked_mutex);
    if (!mask_checked.emplace(frame.mask_path, agrees).second) return agrees;  // another thread named it
  }
  if (agrees) return true;
  const double pixels = static_cast<double>(mask.total());
  const bool replace = config.supplied_masks == CaptureConfig::SuppliedMasks::replace_poor;
  spdlog::warn("{}: the mask covers {:.1f}% of the image, the posed hands {:.1f}% (IoU {:.2f}): the "
               "mask or the pose is wrong ({})", frame.mask_path, 100.0 * cv::countNonZero(mask) / pixels,
               100.0 * cv::countNonZero(mesh) / pixels, iou,
               replace ? "data.supplied_masks=replace_poor: the posed meshes' mask is used instead"
                       : "set data.supplied_masks=replace_poor, or remove the mask file, to use the "
                         "posed meshes' mask");
  return false;
}

cv::Mat Capture::Impl::compute_mask(const FrameInfo& frame, const cv::Mat& bgr) const {
  if (!config.mask_refine.enabled) return posed_mesh_mask(frame);
  // Hand by hand: the largest component of a pair is one hand when the two stand apart.
  const std::vector<float>& vertices = posed_vertices.at(frame.pose_index);
  const int64_t hands = num_faces(frame.pose_index) / faces_per_hand;
  cv::Mat mask;
  for (int64_t h = 0; h < hands; ++h) {
    cv::Mat hand = mesh_mask(vertices.data(), static_cast<int64_t>(vertices.size() / 3),
                             faces.data() + h * faces_per_hand * 3, faces_per_hand, frame.camera);
    cv::Mat refined = hand.clone();
    refine_mask(refined, bgr, config.mask_refine);
    // A refinement that removes everything (e.g. a badly exposed frame) would leave the hand
    // without supervision: keep its mesh mask then.
    if (cv::countNonZero(refined) > 0) hand = refined;
    mask = mask.empty() ? hand : (mask | hand);
  }
  return mask;
}

cv::Mat Capture::Impl::mask_for(const FrameInfo& frame, const cv::Mat& bgr) const {
  if (!frame.mask_path.empty()) {
    const std::string bytes = read_image_bytes(frame.mask_path);
    // Walked before decoding: libpng would print its own lines, without the path, first.
    if (is_png_data(bytes))
      if (const std::string damage = png_damage(bytes); !damage.empty())
        throw Error(frame.mask_path + ": damaged PNG mask (" + damage + ")");
    cv::Mat stored = decode_image_bytes(bytes, cv::IMREAD_GRAYSCALE, frame.mask_path, "mask");
    if (stored.empty()) throw Error(frame.mask_path + ": cannot decode mask");
    if (stored.cols != bgr.cols || stored.rows != bgr.rows)
      throw Error(frame.mask_path + ": mask is " + std::to_string(stored.cols) + "x" +
                  std::to_string(stored.rows) + " but its image " + frame.image_path + " is " +
                  std::to_string(bgr.cols) + "x" + std::to_string(bgr.rows));
    auto maps = undistort.find(frame.camera_id);
    if (maps != undistort.end())  // drawn on the distorted image: nearest keeps it binary
    {
      cv::Mat undone;
      cv::remap(stored, undone, maps->second.map_x, maps->second.map_y, cv::INTER_NEAREST,
                cv::BORDER_CONSTANT, cv::Scalar::all(0));
      stored = undone;
    }
    cv::Mat mask;
    cv::threshold(stored, mask, 127, 1, cv::THRESH_BINARY);
    const bool agrees = check_supplied_mask(frame, mask);
    if (agrees || config.supplied_masks != CaptureConfig::SuppliedMasks::replace_poor) return mask;
  }
  if (mask_folder.empty()) return compute_mask(frame, bgr);
  const fs::path file = fs::path(mask_folder) / fs::path(frame.file_name).replace_extension(".png");
  if (std::error_code ec; fs::is_regular_file(file, ec)) {
    cv::Mat stored = read_cached(file, cv::IMREAD_GRAYSCALE);
    if (stored.cols == bgr.cols && stored.rows == bgr.rows) {
      cv::Mat mask;
      cv::threshold(stored, mask, 127, 1, cv::THRESH_BINARY);
      return mask;
    }
    // Unreadable or stale: recompute and overwrite below.
  }
  cv::Mat mask = compute_mask(frame, bgr);
  std::vector<uint8_t> png;
  cv::Mat visible = mask * 255;  // 0/255 so the cached file can be looked at
  cv::imencode(".png", visible, png);
  ensure_directory(file.parent_path().string());
  write_cache_file(file, png);
  return mask;
}

std::shared_ptr<const CachedCrop> Capture::Impl::produce(int64_t index, bool full) const {
  const FrameInfo& frame = frames.at(index);
  const cv::Mat bgr = decode(frame);
  const cv::Mat mask = mask_for(frame, bgr);
  auto crop = std::make_shared<CachedCrop>();
  crop->roi = full ? PixelRect{0, 0, bgr.cols, bgr.rows} : roi_from_mask(mask, config.roi_margin);
  const cv::Rect rect(crop->roi.x0, crop->roi.y0, crop->roi.width(), crop->roi.height());
  cv::cvtColor(bgr(rect), crop->rgb, cv::COLOR_BGR2RGB);  // new, continuous buffer
  crop->mask = mask(rect).clone();
  return crop;
}

std::shared_ptr<const CachedCrop> Capture::Impl::get(int64_t index, bool full) {
  require(index >= 0 && index < static_cast<int64_t>(frames.size()),
          "Capture::load: frame index " + std::to_string(index) + " out of range (" +
              std::to_string(frames.size()) + " frames)");
  const uint64_t k = key(index, full);
  if (auto crop = cache.get(k)) return crop;
  {
    std::unique_lock<std::mutex> lock(mutex);
    // A loader thread is decoding this frame: wait for it instead of decoding twice.
    done_cv.wait(lock, [&] { return !in_flight.count(k); });
    auto error = errors.find(k);
    if (error != errors.end()) {
      std::exception_ptr e = error->second;
      errors.erase(error);
      std::rethrow_exception(e);
    }
    if (auto crop = cache.get(k)) return crop;
    in_flight.insert(k);
  }
  std::shared_ptr<const CachedCrop> crop;
  try {
    crop = produce(index, full);
  } catch (...) {
    std::lock_guard<std::mutex> lock(mutex);
    in_flight.erase(k);
    done_cv.notify_all();
    throw;
  }
  cache.put(k, crop);
  std::lock_guard<std::mutex> lock(mutex);
  in_flight.erase(k);
  done_cv.notify_all();
  return crop;
}

void Capture::Impl::worker_loop() {
  while (true) {
    uint64_t k = 0;
    {
      std::unique_lock<std::mutex> lock(mutex);
      work_cv.wait(lock, [&] { return stopping || !queue.empty(); });
      if (stopping) return;
      k = queue.front();
      queue.pop_front();
      if (in_flight.count(k) || cache.contains(k)) continue;
      in_flight.insert(k);
    }
    std::shared_ptr<const CachedCrop> crop;
    std::exception_ptr failure;
    try {
      crop = produce(static_cast<int64_t>(k / 2), (k & 1) != 0);
    } catch (...) {
      failure = std::current_exception();
    }
    if (crop) cache.put(k, crop);
    std::lock_guard<std::mutex> lock(mutex);
    if (failure) {
      if (errors.size() >= kMaxRememberedErrors) errors.erase(errors.begin());
      errors[k] = failure;
    }
    in_flight.erase(k);
    done_cv.notify_all();
  }
}

void Capture::Impl::start_workers(int count) {
  for (int i = 0; i < count; ++i) workers.emplace_back([this] { worker_loop(); });
}

void Capture::Impl::stop_workers() {
  {
    std::lock_guard<std::mutex> lock(mutex);
    stopping = true;
    queue.clear();
  }
  work_cv.notify_all();
  for (auto& worker : workers)
    if (worker.joinable()) worker.join();
  workers.clear();
}

FrameSample Capture::load(const FrameInfo& frame, bool full_image) {
  std::shared_ptr<const CachedCrop> crop = impl_->get(frame.index, full_image);
  FrameSample sample;
  sample.index = frame.index;
  sample.camera = impl_->frames.at(frame.index).camera;
  sample.roi = crop->roi;
  const int64_t h = crop->rgb.rows, w = crop->rgb.cols;
  // Copies (about 0.2 MB for a hand crop), so the cached buffers stay immutable. memcpy rather than
  // Tensor::clone: clone runs an OpenMP region, whose idle threads then spin and compete with the
  // loader threads.
  sample.image = torch::empty({h, w, 3}, torch::kUInt8);
  sample.mask = torch::empty({h, w}, torch::kUInt8);
  std::memcpy(sample.image.data_ptr<uint8_t>(), crop->rgb.data, static_cast<size_t>(h * w * 3));
  std::memcpy(sample.mask.data_ptr<uint8_t>(), crop->mask.data, static_cast<size_t>(h * w));
  return sample;
}

void Capture::prefetch(const std::vector<int64_t>& indices, bool full_image) {
  {
    std::lock_guard<std::mutex> lock(impl_->mutex);
    impl_->queue.clear();
    for (int64_t index : indices)
      if (index >= 0 && index < static_cast<int64_t>(impl_->frames.size()))
        impl_->queue.push_back(Impl::key(index, full_image));
  }
  impl_->work_cv.notify_all();
}

cv::Mat Capture::decode_image(const FrameInfo& frame) const { return impl_->decode(frame); }

cv::Mat Capture::compute_mask(const FrameInfo& frame, const cv::Mat& bgr) const {
  return impl_->compute_mask(frame, bgr);
}

}  // namespace handscs
