#include "data/crop_cache.h"

namespace handscs {

namespace {
// Allowance for the two cv::Mat headers, the shared_ptr control block and the list/map nodes.
constexpr size_t kEntryOverheadBytes = 512;
}  // namespace

size_t CachedCrop::bytes() const {
  return rgb.total() * rgb.elemSize() + mask.total() * mask.elemSize() + kEntryOverheadBytes;
}

std::shared_ptr<const CachedCrop> CropCache::get(uint64_t key) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = index_.find(key);
  if (it == index_.end()) {
    ++stats_.misses;
    return nullptr;
  }
  ++stats_.hits;
  order_.splice(order_.begin(), order_, it->second);
  return it->second->crop;
}

bool CropCache::contains(uint64_t key) const {
  std::lock_guard<std::mutex> lock(mutex_);
  return index_.count(key) != 0;
}

void CropCache::put(uint64_t key, std::shared_ptr<const CachedCrop> crop) {
  if (!crop) return;
  const size_t size = crop->bytes();
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = index_.find(key);
  if (it != index_.end()) {
    bytes_ -= it->second->bytes;
    order_.erase(it->second);
    index_.erase(it);
  }
  if (size > budget_) return;
  evict_to(budget_ - size);
  order_.push_front(Entry{key, std::move(crop), size});
  index_[key] = order_.begin();
  bytes_ += size;
}

void CropCache::evict_to(size_t limit) {
  while (bytes_ > limit && !order_.empty()) {
    const Entry& last = order_.back();
    bytes_ -= last.bytes;
    index_.erase(last.key);
    order_.pop_back();
    ++stats_.evictions;
  }
}

void CropCache::clear() {
  std::lock_guard<std::mutex> lock(mutex_);
  order_.clear();
  index_.clear();
  bytes_ = 0;
}

size_t CropCache::bytes() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return bytes_;
}

size_t CropCache::size() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return order_.size();
}

CropCacheStats CropCache::stats() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return stats_;
}

}  // namespace handscs
