// The benchmarks' timing helpers: elapsed time and the median they report (warm-up runs are the
// caller's to drop). One home for what every handscs-bench-* executable needs.
#pragma once

#include <algorithm>
#include <chrono>
#include <vector>

namespace bench {

using Clock = std::chrono::steady_clock;

inline double ms_since(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

inline double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// Milliseconds that f() takes.
template <class F>
double ms_of(F&& f) {
  const auto start = Clock::now();
  f();
  return ms_since(start);
}

// The middle value (the upper one of an even count); 0 for none.
inline double median(std::vector<double> values) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  return values[values.size() / 2];
}

}  // namespace bench
