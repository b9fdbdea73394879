#include "render/binning.h"

#include <algorithm>
#include <cstring>
#include <limits>

#include <omp.h>

#include "render/projection.h"

namespace handscs {

namespace {

// Stable LSD radix sort of `ids` by the bit patterns of positive depths (for positive IEEE floats the bit
// pattern orders like the value). 8-bit digits: 4 passes for float, 8 for double.
template <class T>
void sort_by_depth(std::vector<int32_t>& ids, const T* splats) {
  using Key = std::conditional_t<sizeof(T) == 4, uint32_t, uint64_t>;
  const size_t n = ids.size();
  std::vector<Key> keys(n), keys_tmp(n);
  std::vector<int32_t> ids_tmp(n);
  for (size_t i = 0; i < n; ++i) {
    const T z = splats[int64_t(ids[i]) * kSplatFields + kSplatDepth];
    std::memcpy(&keys[i], &z, sizeof(Key));
  }
  for (unsigned shift = 0; shift < 8 * sizeof(Key); shift += 8) {
    size_t count[257] = {};
    for (size_t i = 0; i < n; ++i) ++count[((keys[i] >> shift) & 0xff) + 1];
    if (count[((keys[0] >> shift) & 0xff) + 1] == n) continue;  // all keys share this digit
    for (int d = 0; d < 256; ++d) count[d + 1] += count[d];
    for (size_t i = 0; i < n; ++i) {
      const size_t pos = count[(keys[i] >> shift) & 0xff]++;
      keys_tmp[pos] = keys[i];
      ids_tmp[pos] = ids[i];
    }
    keys.swap(keys_tmp);
    ids.swap(ids_tmp);
  }
}

}  // namespace

template <class T>
bool bin_splats(const RasterFrame& frame, int64_t n, const T* splats, const int32_t* rects, TileBins& bins) {
  const int tiles_x = frame.tiles_x, num_tiles = frame.num_tiles();
  bins.tile_offsets.assign(num_tiles + 1, 0);
  bins.gaussian_offsets.assign(n + 1, 0);
  bins.tile_gaussians.clear();
  bins.entry_slots.clear();

  std::vector<int32_t> visible;
  visible.reserve(n);
  int64_t total = 0;
  for (int64_t i = 0; i < n; ++i) {
    const int32_t* r = rects + kRectFields * i;
    int64_t tiles = 0;
    if (r[kRectX0] < r[kRectX1] && r[kRectY0] < r[kRectY1]) {
      tiles = int64_t((r[kRectX1] - 1) / kTileSize - r[kRectX0] / kTileSize + 1) *
              ((r[kRectY1] - 1) / kTileSize - r[kRectY0] / kTileSize + 1);
      visible.push_back(int32_t(i));
    }
    total += tiles;
    if (total > std::numeric_limits<int32_t>::max()) {
      bins.gaussian_offsets.assign(n + 1, 0);
      return false;
    }
    bins.gaussian_offsets[i + 1] = int32_t(total);
  }
  if (visible.empty()) return true;
  sort_by_depth(visible, splats);

  // Count and fill in parallel over contiguous chunks of the depth order: thread t's entries in a tile go after
  // those of threads < t, so the lists come out exactly as a serial front-to-back pass would make them.
  const int threads = std::max(1, std::min(omp_get_max_threads(), int(visible.size() / 1024) + 1));
  const int64_t num_visible = int64_t(visible.size());
  std::vector<int32_t> counts(size_t(threads) * num_tiles, 0);
  bins.tile_gaussians.resize(total);
  bins.entry_slots.resize(total);
  std::vector<int32_t>& offsets = bins.tile_offsets;
#pragma omp parallel num_threads(threads)
  {
    // The team may be smaller than asked for (nested regions): chunk by the actual team size.
    const int t = omp_get_thread_num(), team = omp_get_num_threads();
    const int64_t lo = num_visible * t / team, hi = num_visible * (t + 1) / team;
    int32_t* count = counts.data() + size_t(t) * num_tiles;
    for (int64_t v = lo; v < hi; ++v) {
      const int32_t* r = rects + kRectFields * int64_t(visible[v]);
      for (int ty = r[kRectY0] / kTileSize; ty <= (r[kRectY1] - 1) / kTileSize; ++ty)
        for (int tx = r[kRectX0] / kTileSize; tx <= (r[kRectX1] - 1) / kTileSize; ++tx) ++count[ty * tiles_x + tx];
    }
#pragma omp barrier
#pragma omp single
    {
      // counts[t][k] becomes thread t's first position in tile k.
      int32_t pos = 0;
      for (int k = 0; k < num_tiles; ++k) {
        offsets[k] = pos;
        for (int u = 0; u < team; ++u) {
          const int32_t c = counts[size_t(u) * num_tiles + k];
          counts[size_t(u) * num_tiles + k] = pos;
          pos += c;
        }
      }
      offsets[num_tiles] = pos;
    }
    for (int64_t v = lo; v < hi; ++v) {
      const int32_t i = visible[v];
      const int32_t* r = rects + kRectFields * int64_t(i);
      int32_t slot = bins.gaussian_offsets[i];
      for (int ty = r[kRectY0] / kTileSize; ty <= (r[kRectY1] - 1) / kTileSize; ++ty)
        for (int tx = r[kRectX0] / kTileSize; tx <= (r[kRectX1] - 1) / kTileSize; ++tx) {
          const int32_t pos = count[ty * tiles_x + tx]++;
          bins.tile_gaussians[pos] = i;
          bins.entry_slots[pos] = slot++;
        }
    }
  }
  return true;
}

template bool bin_splats<float>(const RasterFrame&, int64_t, const float*, const int32_t*, TileBins&);
template bool bin_splats<double>(const RasterFrame&, int64_t, const double*, const int32_t*, TileBins&);

}  // namespace handscs
