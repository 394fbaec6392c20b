#pragma once
// The median of many samples (a dwell's 15 000 readings per axis, twice per axis for the
// outlier rule's median and MAD), exact and in linear time with a small constant.
// std::nth_element took a fifth of `fit`'s CPU (docs/performance.md); here the values are
// first counted into buckets of equal width between their least and greatest, and only the
// bucket that holds the wanted rank is selected from. Bucketing is monotone, so every
// value of a lower bucket is <= every value of a higher one and the rank found is exact
// whatever the distribution: an outlier that widens the buckets only makes the chosen
// bucket fuller, never the answer different.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

namespace standcal {

namespace detail {

inline constexpr std::uint32_t kMedianBuckets = 2048;
// Below this many values, plain selection: the buckets' table would outweigh the values.
inline constexpr std::size_t kFewValues = 512;

// The values of rank `rank` and, when `with_previous`, rank - 1 (0-based, ascending), as
// std::nth_element and a max over the values before it give them; `values` is reordered.
inline std::pair<double, double> select_by_nth_element(std::vector<double>& values,
                                                       std::size_t rank, bool with_previous) {
  const auto at = values.begin() + static_cast<std::ptrdiff_t>(rank);
  std::nth_element(values.begin(), at, values.end());
  const double previous = with_previous && rank > 0 ? *std::max_element(values.begin(), at) : *at;
  return {*at, previous};
}

// Least and greatest of `n` values, in four independent lanes (one lane is a chain of
// dependent compares, four times slower).
inline std::pair<double, double> least_and_greatest(const double* x, std::size_t n) {
  std::array<double, 4> lo{x[0], x[0], x[0], x[0]}, hi = lo;
  std::size_t i = 0;
  for (; i + 4 <= n; i += 4)
    for (std::size_t j = 0; j < 4; ++j) {
      lo[j] = x[i + j] < lo[j] ? x[i + j] : lo[j];
      hi[j] = x[i + j] > hi[j] ? x[i + j] : hi[j];
    }
  for (; i < n; ++i) {
    lo[0] = x[i] < lo[0] ? x[i] : lo[0];
    hi[0] = x[i] > hi[0] ? x[i] : hi[0];
  }
  return {std::min(std::min(lo[0], lo[1]), std::min(lo[2], lo[3])),
          std::max(std::max(hi[0], hi[1]), std::max(hi[2], hi[3]))};
}

// The same pair, selected from the one bucket that holds rank `rank`.
inline std::pair<double, double> ranked_pair(std::vector<double>& values, std::size_t rank,
                                             bool with_previous) {
  const std::size_t n = values.size();
  const double* x = values.data();
  const auto [low, high] = least_and_greatest(x, n);
  const double width = high - low;
  if (n < kFewValues || !(width > 0) || !std::isfinite(width))
    return select_by_nth_element(values, rank, with_previous);
  const double scale = kMedianBuckets / width;
  std::vector<std::uint16_t> bucket_of(n);
  std::array<std::uint32_t, kMedianBuckets> counts{};
  for (std::size_t i = 0; i < n; ++i) {
    const double at = (x[i] - low) * scale;  // in [0, kMedianBuckets]
    const std::uint32_t b =
        at < kMedianBuckets - 1 ? static_cast<std::uint32_t>(at) : kMedianBuckets - 1;
    bucket_of[i] = static_cast<std::uint16_t>(b);
    ++counts[b];
  }
  std::uint32_t bucket = 0;
  std::size_t below = 0;
  while (below + counts[bucket] <= rank) below += counts[bucket++];
  std::vector<double> chosen(counts[bucket]);
  for (std::size_t i = 0, c = 0; i < n; ++i)
    if (bucket_of[i] == bucket) chosen[c++] = x[i];
  const std::size_t local = rank - below;
  auto [value, previous] = select_by_nth_element(chosen, local, with_previous);
  if (with_previous && rank > 0 && local == 0) {  // rank - 1 is the lower buckets' greatest
    previous = low;
    for (std::size_t i = 0; i < n; ++i)
      if (bucket_of[i] < bucket && x[i] > previous) previous = x[i];
  }
  return {value, previous};
}

}  // namespace detail

// The median of `values` (the mean of the two middle values when their count is even);
// `values` is reordered, and must be neither empty nor hold NaN (NaN has no rank).
inline double median_in_place(std::vector<double>& values) {
  const std::size_t mid = values.size() / 2;
  const bool even = values.size() % 2 == 0;
  const auto [upper, lower] = detail::ranked_pair(values, mid, even);
  return even ? 0.5 * (lower + upper) : upper;
}

}  // namespace standcal
