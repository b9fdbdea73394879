// The benchmarks' timing helpers: elapsed time and the median they report (warm-up runs are the
// caller's to drop). One home for what every handscs-bench-* executable needs.
#pragma once

#include <algorithm>
#include <chrono>
#include <fstream>
#include <string>
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

struct Timing {
  double median_ms = 0, min_ms = 0;
};

// The median and the fastest of `repeats` timed calls of f(), after `warmup` untimed ones.
template <class F>
Timing time_repeated(F&& f, int warmup, int repeats) {
  for (int i = 0; i < warmup; ++i) f();
  std::vector<double> ms;
  for (int i = 0; i < repeats; ++i) ms.push_back(ms_of(f));
  return {median(ms), ms.empty() ? 0.0 : *std::min_element(ms.begin(), ms.end())};
}

// The first three fields of /proc/loadavg: other processes competing for the cores skew every
// timing, so a benchmark records them.
inline std::string load_average() {
  std::ifstream in("/proc/loadavg");
  std::string one, five, fifteen;
  in >> one >> five >> fifteen;
  return one + " " + five + " " + fifteen;
}

}  // namespace bench
