// LRU crop cache: never holds more bytes than its budget, evicts least recently used first, and
// survives concurrent use.
#include <atomic>
#include <thread>

#include "data/crop_cache.h"

// Catch last: LibTorch pulls in glog, whose CHECK macro would otherwise replace Catch's.
#include <catch2/catch.hpp>

using namespace handscs;

namespace {
std::shared_ptr<const CachedCrop> crop_of(int w, int h) {
  auto crop = std::make_shared<CachedCrop>();
  crop->roi = PixelRect{0, 0, w, h};
  crop->rgb = cv::Mat(h, w, CV_8UC3, cv::Scalar(1, 2, 3));
  crop->mask = cv::Mat(h, w, CV_8UC1, cv::Scalar(1));
  return crop;
}
}  // namespace

TEST_CASE("crop cache: byte budget and LRU order") {
  const size_t one = crop_of(100, 100)->bytes();
  CHECK(one == 100 * 100 * 4 + 512);
  CropCache cache(3 * one + 10);
  for (uint64_t k = 0; k < 3; ++k) cache.put(k, crop_of(100, 100));
  CHECK(cache.size() == 3);
  CHECK(cache.bytes() == 3 * one);
  REQUIRE(cache.get(0));  // 0 becomes most recent; 1 is now the oldest
  cache.put(3, crop_of(100, 100));
  CHECK(cache.size() == 3);
  CHECK(cache.contains(0));
  CHECK_FALSE(cache.contains(1));
  CHECK(cache.contains(2));
  CHECK(cache.contains(3));
  CHECK(cache.stats().evictions == 1);
  CHECK(cache.get(1) == nullptr);
  CHECK(cache.stats().misses == 1);
  // A larger crop evicts as many as needed; one larger than the budget is not stored at all.
  cache.put(4, crop_of(200, 100));
  CHECK(cache.bytes() <= cache.budget());
  CHECK(cache.contains(4));
  CHECK_FALSE(cache.contains(2));
  cache.put(5, crop_of(400, 400));
  CHECK_FALSE(cache.contains(5));
  CHECK(cache.bytes() <= cache.budget());
  // Replacing a key does not double count.
  const size_t before = cache.bytes();
  cache.put(4, crop_of(200, 100));
  CHECK(cache.bytes() == before);
  cache.clear();
  CHECK(cache.bytes() == 0);
  CHECK(cache.size() == 0);
}

TEST_CASE("crop cache: concurrent puts and gets stay within budget") {
  const size_t one = crop_of(64, 48)->bytes();
  CropCache cache(20 * one);
  std::vector<std::thread> threads;
  std::atomic<bool> over{false};
  for (int t = 0; t < 4; ++t)
    threads.emplace_back([&, t] {
      for (int i = 0; i < 500; ++i) {
        const uint64_t k = static_cast<uint64_t>((i * 7 + t * 13) % 97);
        if (!cache.get(k)) cache.put(k, crop_of(64, 48));
        if (cache.bytes() > cache.budget()) over = true;
      }
    });
  for (auto& thread : threads) thread.join();
  CHECK_FALSE(over);
  CHECK(cache.size() == 20);
  CHECK(cache.bytes() == 20 * one);
}
