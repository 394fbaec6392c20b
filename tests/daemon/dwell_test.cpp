// The dwell's average and stability rule (daemon/standcald/dwell.hpp), without a daemon.
#include "daemon/standcald/dwell.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace standcal::daemon {
namespace {

constexpr double kG = 9.80665;
constexpr double kUgMps2 = kG * 1e-6;

// `n` samples at `rate_hz`: x alternates ±sigma_x (so its sample σ is known exactly),
// y rises linearly by `rise_y` over the dwell, z is constant 1 g; temperature 25 °C.
std::vector<drivers::AccelSample> dwell_samples(int n, double rate_hz, double sigma_x,
                                                double rise_y) {
  std::vector<drivers::AccelSample> s;
  const double span_s = (n - 1) / rate_hz;
  for (int i = 0; i < n; ++i) {
    drivers::AccelSample x;
    x.t_s = 1000 + i / rate_hz;
    x.force_mps2 = {0.01 + (i % 2 == 0 ? sigma_x : -sigma_x), 0.2 + rise_y * (i / rate_hz) / span_s,
                    kG};
    x.temperature_c = 25;
    s.push_back(x);
  }
  return s;
}

DwellExpectation expect(double dwell_s, double rate_hz, std::uint64_t incomplete = 0) {
  return DwellExpectation{"sim", dwell_s, rate_hz, incomplete, kG};
}

TEST(DwellAverage, MeanSigmaAndTrendPerAxis) {
  const int n = 1000;
  const auto d = average_dwell(dwell_samples(n, 100, 1e-3, 5e-4));
  EXPECT_EQ(d.count, 1000u);
  EXPECT_NEAR(d.mean_mps2[0], 0.01, 1e-12);
  EXPECT_NEAR(d.mean_mps2[1], 0.2 + 2.5e-4, 1e-12);  // the middle of the ramp
  EXPECT_NEAR(d.mean_mps2[2], kG, 1e-12);
  // ±s alternating: sample variance n s² / (n - 1).
  EXPECT_NEAR(d.sigma_mps2[0], 1e-3 * std::sqrt(n / (n - 1.0)), 1e-12);
  EXPECT_NEAR(d.trend_mps2[1], 5e-4, 1e-12);  // the whole rise over the dwell
  EXPECT_NEAR(d.trend_mps2[2], 0, 1e-12);
  EXPECT_DOUBLE_EQ(d.temp_mean_c, 25);
}

TEST(DwellAverage, NoSamplesAndNoTemperatureAreSaidSo) {
  const auto empty = average_dwell({});
  EXPECT_EQ(empty.count, 0u);
  EXPECT_TRUE(std::isnan(empty.temp_mean_c));
  auto s = dwell_samples(10, 100, 0, 0);
  for (auto& x : s) x.temperature_c = std::nan("");
  const auto d = average_dwell(s);
  EXPECT_TRUE(std::isnan(d.temp_mean_c));
  EXPECT_EQ(d.sigma_mps2[2], 0);
}

TEST(DwellStability, AQuietCompleteDwellIsKept) {
  const StabilityRule rule;
  EXPECT_EQ(dwell_problem(average_dwell(dwell_samples(1000, 100, 100 * kUgMps2, 0)),
                          expect(10, 100), rule),
            "");
}

TEST(DwellStability, EachReasonIsNamedInTheOperatorsWords) {
  StabilityRule rule;
  // Nothing at all, and no incomplete frame either: the unit said nothing.
  EXPECT_EQ(dwell_problem(average_dwell({}), expect(2.5, 100), rule),
            "no sample from the accelerometer unit sim during the 2.5 s dwell (is it powered and "
            "on the bus?)");
  // 800 of 1000 with the default 90 %.
  EXPECT_EQ(dwell_problem(average_dwell(dwell_samples(800, 100, 0, 0)), expect(10, 100, 7), rule),
            "only 800 of 1000 expected samples (7 incomplete)");
  // x noisier than the limit (σ = 6000 µg √(1000/999) against 5000 µg).
  const std::string noisy = dwell_problem(
      average_dwell(dwell_samples(1000, 100, 6000 * kUgMps2, 0)), expect(10, 100), rule);
  ASSERT_EQ(noisy.rfind("axis x noise ", 0), 0u) << noisy;
  EXPECT_NEAR(std::stod(noisy.substr(13)), 6000 * std::sqrt(1000 / 999.0), 1e-3) << noisy;
  EXPECT_NE(noisy.find("µg above the limit 5000 µg"), std::string::npos) << noisy;
  // y drifted 2500 µg over the dwell against 2000 µg.
  const std::string drift = dwell_problem(
      average_dwell(dwell_samples(1000, 100, 0, 2500 * kUgMps2)), expect(10, 100), rule);
  ASSERT_EQ(drift.rfind("axis y drifted ", 0), 0u) << drift;
  EXPECT_NEAR(std::stod(drift.substr(15)), 2500, 1e-3) << drift;
  EXPECT_NE(drift.find("µg during the dwell (limit 2000 µg)"), std::string::npos) << drift;
  // The limits are the rule's.
  rule.trend_limit_ug = 3000;
  EXPECT_EQ(dwell_problem(average_dwell(dwell_samples(1000, 100, 0, 2500 * kUgMps2)),
                          expect(10, 100), rule),
            "");
}

}  // namespace
}  // namespace standcal::daemon
