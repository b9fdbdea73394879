#include "sweep/pareto.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "core/error.h"

namespace handscs {

std::vector<size_t> pareto_front(const std::vector<double>& x, const std::vector<double>& y, bool maximize_y) {
  require(x.size() == y.size(), "pareto_front: x has " + std::to_string(x.size()) + " values, y has " +
                                    std::to_string(y.size()));
  // Work with a quality to maximise: q = y or -y.
  const double sign = maximize_y ? 1.0 : -1.0;
  std::vector<size_t> order;
  for (size_t i = 0; i < x.size(); ++i)
    if (std::isfinite(x[i]) && std::isfinite(y[i])) order.push_back(i);
  // Cheapest first; at equal cost the best quality first; then by index, so the output is deterministic.
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    if (x[a] != x[b]) return x[a] < x[b];
    if (sign * y[a] != sign * y[b]) return sign * y[a] > sign * y[b];
    return a < b;
  });

  std::vector<size_t> front;
  double best_cheaper = -std::numeric_limits<double>::infinity();  // best q among strictly cheaper points
  for (size_t begin = 0; begin < order.size();) {
    size_t end = begin;
    while (end < order.size() && x[order[end]] == x[order[begin]]) ++end;
    // Within a group of equal cost only the best quality survives (others are strictly worse in q);
    // it survives overall when it beats every cheaper point strictly (equal q at lower cost dominates).
    const double group_best = sign * y[order[begin]];
    if (group_best > best_cheaper)
      for (size_t k = begin; k < end && sign * y[order[k]] == group_best; ++k) front.push_back(order[k]);
    best_cheaper = std::max(best_cheaper, group_best);
    begin = end;
  }
  return front;
}

}  // namespace handscs
