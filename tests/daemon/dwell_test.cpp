// The dwell's average and stability rule (daemon/standcald/dwell.hpp), without a daemon.
#include "daemon/standcald/dwell.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "tests/support/statistical.hpp"

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

// `n` samples at `rate_hz`, each axis white with sigma `white_ug` plus a Gauss-Markov wander
// (`wander_ug`, `tau_s`), started stationary; y also rises by `rise_y_ug` over the dwell.
std::vector<drivers::AccelSample> noisy_dwell(int n, double rate_hz, double white_ug,
                                              double wander_ug, double tau_s, double rise_y_ug,
                                              std::mt19937_64& rng) {
  std::normal_distribution<double> gauss(0, 1);
  const double phi = std::exp(-1 / (rate_hz * tau_s));
  const double drive = wander_ug * std::sqrt(1 - phi * phi);
  std::array<double, 3> b{wander_ug * gauss(rng), wander_ug * gauss(rng), wander_ug * gauss(rng)};
  std::vector<drivers::AccelSample> s;
  for (int i = 0; i < n; ++i) {
    drivers::AccelSample x;
    x.t_s = 1000 + i / rate_hz;
    for (int a = 0; a < 3; ++a) {
      b[a] = phi * b[a] + drive * gauss(rng);
      x.force_mps2[a] = (a == 2 ? kG : 0.0) + (b[a] + white_ug * gauss(rng)) * kUgMps2;
    }
    x.force_mps2[1] += rise_y_ug * kUgMps2 * i / (n - 1.0);
    s.push_back(x);
  }
  return s;
}

// The trend the noise explains is the scatter of the trends of simulated dwells: 2000
// dwells of 500 samples at 50 Hz (the sd of a sample sd of 2000 is 1.6 %: 5 % holds).
TEST(DwellStability, TheExplainedTrendIsTheScatterOfSimulatedDwellsTrends) {
  STANDCAL_STATISTICAL_TEST();
  std::mt19937_64 rng(31);
  for (const double wander_ug : {0.0, 40.0}) {
    constexpr int kDwells = 2000, kSamples = 500;
    constexpr double kRateHz = 50, kWhiteUg = 50, kTauS = 30;
    double sum_sq = 0, gain = 0;
    for (int k = 0; k < kDwells; ++k) {
      const auto d =
          average_dwell(noisy_dwell(kSamples, kRateHz, kWhiteUg, wander_ug, kTauS, 0, rng));
      sum_sq += std::pow(d.trend_mps2[0] / kUgMps2, 2);
      gain = d.trend_gain;
    }
    EXPECT_NEAR(gain, std::sqrt(12.0 * (kSamples - 1) / (kSamples * (kSamples + 1.0))), 1e-9);
    const double span_s = (kSamples - 1) / kRateHz;
    const double predicted =
        std::hypot(kWhiteUg * gain, wander_trend_sigma(span_s, wander_ug, kTauS));
    EXPECT_NEAR(std::sqrt(sum_sq / kDwells) / predicted, 1.0, 0.05) << "wander " << wander_ug;
  }
  // A wander slow against the dwell drifts it as a random walk, 12 q^2 T / (5 tau); a fast
  // one is white noise of density 2 q^2 tau, 24 q^2 tau / T. (A 256-step midpoint rule
  // gave the fast case 1.4 times the variance.)
  EXPECT_NEAR(wander_trend_sigma(10, 40, 3000), std::sqrt(12 * 40.0 * 40.0 * 10 / (5 * 3000)),
              0.01 * std::sqrt(12 * 1600.0 / 1500));
  EXPECT_NEAR(wander_trend_sigma(600, 40, 1), std::sqrt(24 * 1600.0 / 600), 0.01 * 8);
  EXPECT_EQ(wander_trend_sigma(600, 0, 1), 0);
}

// A dwell whose samples carry no noise gives no measure to judge its drift against: the
// rule keeps it (the absolute trend limit still applies).
TEST(DwellStability, ANoiseFreeDwellIsNotJudgedAgainstItsNoise) {
  StabilityRule rule;
  rule.trend_limit_sigmas = 6;
  EXPECT_EQ(dwell_problem(average_dwell(dwell_samples(1000, 100, 0, 100 * kUgMps2)),
                          expect(10, 100), rule),
            "");
}

// With trend_limit_sigmas set, a drift the noise cannot explain is re-measured; the unit's
// configured wander is part of what explains one.
TEST(DwellStability, ADriftBeyondWhatTheNoiseExplainsIsReMeasuredWhenTheRuleAsks) {
  std::mt19937_64 rng(5);
  // 100 ug white over 1000 samples explains about 11 ug of drift; y drifts 100 ug.
  const DwellAverage drifting = average_dwell(noisy_dwell(1000, 100, 100, 0, 300, 100, rng));
  StabilityRule rule;
  EXPECT_EQ(dwell_problem(drifting, expect(10, 100), rule), "") << "off unless asked for";
  rule.trend_limit_sigmas = 6;
  const std::string problem = dwell_problem(drifting, expect(10, 100), rule);
  ASSERT_EQ(problem.rfind("axis y drifted ", 0), 0u) << problem;
  EXPECT_NE(problem.find("times what its noise explains"), std::string::npos) << problem;
  EXPECT_NE(problem.find("limit 6 times"), std::string::npos) << problem;
  // The same dwell from a unit configured with a 100 ug wander of 60 s: explained.
  DwellExpectation wandering = expect(10, 100);
  wandering.bias_wander_ug = 100;
  wandering.bias_wander_tau_s = 60;
  EXPECT_EQ(dwell_problem(drifting, wandering, rule), "");
  // A quiet dwell is kept.
  EXPECT_EQ(dwell_problem(average_dwell(noisy_dwell(1000, 100, 100, 0, 300, 0, rng)),
                          expect(10, 100), rule),
            "");
}

}  // namespace
}  // namespace standcal::daemon
