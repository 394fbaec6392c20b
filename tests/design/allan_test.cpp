// Allan deviation of simulated noise recovers the coefficients it was simulated with.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "calib/allan.hpp"

namespace standcal {
namespace {

constexpr double kRateHz = 100;

// White noise of density N (per sqrt(Hz)): sample sigma N * sqrt(f_s) (docs/model.md), plus
// a rate random walk of K per sqrt(s): the bias steps by K * sqrt(tau0) each sample.
std::vector<double> simulate(double white_density, double random_walk, int samples, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> gauss(0, 1);
  std::vector<double> y(samples);
  double bias = 0;
  for (int k = 0; k < samples; ++k) {
    bias += random_walk * std::sqrt(1.0 / kRateHz) * gauss(rng);
    y[k] = bias + white_density * std::sqrt(kRateHz) * gauss(rng);
  }
  return y;
}

TEST(AllanDeviation, WhiteNoiseGivesItsDensityAtOneSecond) {
  const double n = 10e-6;  // 10 ug/rtHz, in g
  const auto curve = overlapping_allan_deviation({simulate(n, 0, 100000, 1)}, 1.0 / kRateHz);
  ASSERT_GT(curve.size(), 20u);
  EXPECT_NEAR(curve.front().tau_s, 0.01, 1e-12);
  const NoiseFigures f = noise_figures(curve);
  ASSERT_TRUE(f.white_density.has_value());
  EXPECT_NEAR(*f.white_density / n, 1.0, 0.03);
  EXPECT_FALSE(f.random_walk.has_value());
  // The slope is -1/2 throughout: sigma(tau) = N / sqrt(tau) at a well-averaged tau.
  for (const auto& p : curve) {
    if (p.tau_s > 0.05 && p.tau_s < 10) {
      EXPECT_NEAR(p.deviation * std::sqrt(p.tau_s) / n, 1.0, 0.08) << p.tau_s;
    }
  }
}

TEST(AllanDeviation, RandomWalkAndWhiteNoiseBothRecovered) {
  const double n = 10e-6, k = 2e-6;  // crossover at sqrt(3) N / K, about 9 s
  const auto curve = overlapping_allan_deviation({simulate(n, k, 200000, 2)}, 1.0 / kRateHz);
  const NoiseFigures f = noise_figures(curve);
  ASSERT_TRUE(f.white_density.has_value());
  ASSERT_TRUE(f.random_walk.has_value());
  EXPECT_NEAR(*f.white_density / n, 1.0, 0.05);
  EXPECT_NEAR(*f.random_walk / k, 1.0, 0.25);  // few independent long clusters: looser
  ASSERT_TRUE(f.bias_instability.has_value());
  EXPECT_GT(f.bias_instability_tau_s, 2.0);
  EXPECT_LT(f.bias_instability_tau_s, 40.0);
}

TEST(AllanDeviation, SegmentsPoolLikeOneRecording) {
  const double n = 5e-6;
  const auto one = simulate(n, 0, 60000, 3);
  const std::vector<double> a(one.begin(), one.begin() + 30000), b(one.begin() + 30000, one.end());
  const NoiseFigures f = noise_figures(overlapping_allan_deviation({a, b}, 1.0 / kRateHz));
  ASSERT_TRUE(f.white_density.has_value());
  EXPECT_NEAR(*f.white_density / n, 1.0, 0.04);
  EXPECT_THROW(overlapping_allan_deviation({a}, 0.0), std::invalid_argument);
}

}  // namespace
}  // namespace standcal
