// Thread-safe LRU cache of decoded ROI crops (uint8 RGB + mask) under a byte budget: inserting past
// the budget evicts least-recently-used crops first, so memory stays bounded for any capture size.
#pragma once

#include <cstddef>
#include <cstdint>
#include <list>
#include <memory>
#include <mutex>
#include <opencv2/core/mat.hpp>
#include <unordered_map>

#include "core/camera.h"

namespace handscs {

// One decoded frame: the ROI crop of the image and of its mask.
struct CachedCrop {
  PixelRect roi;  // crop rectangle in full-image pixels
  cv::Mat rgb;    // [h, w] CV_8UC3, RGB order, continuous
  cv::Mat mask;   // [h, w] CV_8UC1, 1 = hand, continuous
  // Bytes held: pixel data plus a fixed allowance for the two Mat headers and the cache entry.
  size_t bytes() const;
};

struct CropCacheStats {
  int64_t hits = 0, misses = 0, evictions = 0;
};

class CropCache {
 public:
  explicit CropCache(size_t budget_bytes) : budget_(budget_bytes) {}

  // The crop under `key` (marked most recently used), or nullptr.
  std::shared_ptr<const CachedCrop> get(uint64_t key);
  // True when `key` is cached (does not change the LRU order or the statistics).
  bool contains(uint64_t key) const;
  // Stores a crop, evicting least-recently-used ones until the total fits the budget. A crop larger
  // than the whole budget is not stored. Replaces an existing entry with the same key.
  void put(uint64_t key, std::shared_ptr<const CachedCrop> crop);
  void clear();

  size_t bytes() const;  // bytes currently held (always <= budget())
  size_t size() const;   // number of crops held
  size_t budget() const { return budget_; }
  CropCacheStats stats() const;

 private:
  struct Entry {
    uint64_t key;
    std::shared_ptr<const CachedCrop> crop;
    size_t bytes;
  };
  void evict_to(size_t limit);  // caller holds mutex_

  const size_t budget_;
  mutable std::mutex mutex_;
  std::list<Entry> order_;  // front = most recently used
  std::unordered_map<uint64_t, std::list<Entry>::iterator> index_;
  size_t bytes_ = 0;
  CropCacheStats stats_;
};

}  // namespace handscs
