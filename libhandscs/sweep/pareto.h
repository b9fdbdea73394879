// Pareto front of (cost, quality) points: x is a cost to minimise (e.g. wall time), y a quality to
// maximise (PSNR) or minimise (LPIPS). A point is on the front when no other point dominates it.
#pragma once

#include <cstddef>
#include <vector>

namespace handscs {

// Indices of the points on the Pareto front when x is a cost to minimise (e.g. wall time) and y is a
// quality to maximise (maximize_y = true, e.g. PSNR) or minimise (false, e.g. LPIPS). A point is on
// the front when no other point is at least as good in both and strictly better in one (so identical
// points are all on it). Non-finite points are never on the front. Returned sorted by increasing x
// (equal x by index). Throws Error when x and y differ in length.
std::vector<size_t> pareto_front(const std::vector<double>& x, const std::vector<double>& y, bool maximize_y);

}  // namespace handscs
