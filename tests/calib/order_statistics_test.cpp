// The bucketed median against the definition: sort, take the middle (the mean of the two
// middle values for an even count).
#include "calib/order_statistics.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <vector>

namespace standcal {
namespace {

double sorted_median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t mid = v.size() / 2;
  return v.size() % 2 == 1 ? v[mid] : 0.5 * (v[mid - 1] + v[mid]);
}

void expect_exact_median(const std::vector<double>& values, const std::string& what) {
  std::vector<double> work = values;
  EXPECT_EQ(median_in_place(work), sorted_median(values)) << what << ", " << values.size();
}

TEST(MedianInPlace, IsTheSortedMiddleForEverySizeAndShape) {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> noise(9.81, 3e-4);
  for (std::size_t n : {1u, 2u, 3u, 511u, 512u, 513u, 1000u, 1001u, 15000u, 15001u}) {
    std::vector<double> gaussian(n), spiked(n), quantised(n), clusters(n);
    for (std::size_t i = 0; i < n; ++i) {
      gaussian[i] = noise(rng);
      // One reading in fifty a thousand sigmas off: the buckets are widened by the spikes
      // and the median's bucket holds most of the values.
      spiked[i] = i % 50 == 7 ? 9.81 + 0.3 * (i % 100 == 7 ? 1 : -1) : noise(rng);
      quantised[i] = std::round(noise(rng) / 1e-4) * 1e-4;         // many equal values
      clusters[i] = (i % 2 == 0 ? 0.0 : 1.0) + noise(rng) - 9.81;  // the middle falls in a gap
    }
    expect_exact_median(gaussian, "gaussian");
    expect_exact_median(spiked, "spiked");
    expect_exact_median(quantised, "quantised");
    expect_exact_median(clusters, "two clusters");
    expect_exact_median(std::vector<double>(n, 0.25), "all equal");
  }
}

TEST(MedianInPlace, TakesTheLowerMiddleFromTheBucketsBelowWhenItIsAloneInItsBucket) {
  // 500 values at 0 and 500 at 1: the upper middle (rank 500) is the first value of the top
  // bucket, and the lower middle (rank 499) lies in the bottom one.
  std::vector<double> values(1000, 1.0);
  std::fill(values.begin(), values.begin() + 500, 0.0);
  std::shuffle(values.begin(), values.end(), std::mt19937_64(3));
  expect_exact_median(values, "two values");
  values.push_back(0.5);  // odd count: the lone middle value
  expect_exact_median(values, "two values and a middle one");
}

}  // namespace
}  // namespace standcal
