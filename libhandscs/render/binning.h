// Tile binning: sorts the visible splats by camera depth (stable, so ties keep index order) and lists, for every
// 16x16 tile, the splats whose pixel rectangle overlaps it, front to back; plus a gradient slot per entry, grouped
// by splat, so the backward pass writes each entry's gradient once and sums each splat's contiguous slots in a fixed
// order: no atomics, and the result does not depend on the thread count.
#pragma once

#include <cstdint>
#include <vector>

#include "render/raster_frame.h"

namespace handscs {

struct TileBins {
  std::vector<int32_t> tile_offsets;      // [num_tiles + 1] tile k's entries are [tile_offsets[k], [k + 1])
  std::vector<int32_t> tile_gaussians;    // [num_entries] splat index of each entry, depth order within a tile
  std::vector<int32_t> gaussian_offsets;  // [n + 1] splat i owns gradient slots [gaussian_offsets[i], [i + 1])
  std::vector<int32_t> entry_slots;       // [num_entries] gradient slot of each entry (splat-major order)
  int64_t num_entries() const { return int64_t(tile_gaussians.size()); }
};

// rects: [n, kRectFields] from project_fwd (empty = culled); splats: [n, kSplatFields] (depth is read).
// Returns false (and leaves bins empty) when the entry count would not fit in int32.
template <class T>
bool bin_splats(const RasterFrame& frame, int64_t n, const T* splats, const int32_t* rects, TileBins& bins);

}  // namespace handscs
