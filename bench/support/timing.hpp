#pragma once
// Wall-clock helpers the bench binaries share: seconds since a start, median of repeats.
#include <algorithm>
#include <chrono>
#include <vector>

namespace standcal::bench {

using Clock = std::chrono::steady_clock;

inline double seconds_of(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

inline double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

}  // namespace standcal::bench
