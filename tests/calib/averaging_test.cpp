// Position averaging: mean, standard error, the outlier rule, and the approach rule.
#include <gtest/gtest.h>

#include <random>

#include "calib/averaging.hpp"

using namespace standcal;

namespace {

Recording block_of(const std::vector<Vec3>& f_mps2, int pos = 0, double a1 = 0, double a2 = 0) {
  Recording rec;
  rec.source = "test";
  rec.g_local_mps2 = 9.8;
  rec.settle_s = 5;
  for (std::size_t i = 0; i < f_mps2.size(); ++i) {
    RecordingSample s;
    s.t_s = 10.0 + 0.01 * static_cast<double>(i);
    s.pos = pos;
    s.alpha1_cmd_deg = a1;
    s.alpha2_cmd_deg = a2;
    s.f_mps2 = f_mps2[i];
    rec.samples.push_back(s);
  }
  return rec;
}

std::vector<Vec3> gaussian_samples(int n, double sigma_mps2, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> g(0, sigma_mps2);
  std::vector<Vec3> out;
  for (int i = 0; i < n; ++i) out.emplace_back(g(rng), 9.8 + g(rng), g(rng));
  return out;
}

}  // namespace

TEST(Averaging, MeanAndStandardErrorOfGaussianSamples) {
  const double sigma = 9.8e-4;  // 100 ug
  const auto avg = average_positions(block_of(gaussian_samples(10000, sigma, 7)));
  ASSERT_EQ(avg.size(), 1u);
  EXPECT_EQ(avg[0].samples, 10000u);
  EXPECT_EQ(avg[0].outliers_rejected, 0u);
  EXPECT_NEAR(avg[0].mean_g.y(), 1.0, 4 * 100e-6 / 100);
  EXPECT_NEAR(avg[0].sigma_g.x(), 100e-6, 3e-6);
  EXPECT_NEAR(avg[0].standard_error_g.x(), avg[0].sigma_g.x() / 100, 1e-12);
  EXPECT_DOUBLE_EQ(avg[0].t_arrive_s, 5.0);  // first sample minus settle
}

TEST(Averaging, ASingleGlitchDoesNotMoveTheMean) {
  auto samples = gaussian_samples(2000, 9.8e-5, 11);
  const auto clean = average_positions(block_of(samples));
  samples[1234].y() += 0.5;  // a 50 000 ug spike on one sample
  const auto glitched = average_positions(block_of(samples));
  EXPECT_EQ(glitched[0].outliers_rejected, 1u);
  EXPECT_EQ(glitched[0].samples, 1999u);
  // Dropping one of 2000 samples moves the mean by ~sigma/2000, far below its SE.
  EXPECT_NEAR(glitched[0].mean_g.y(), clean[0].mean_g.y(), 0.1 * clean[0].standard_error_g.y());
}

TEST(Averaging, NoiseFreeDataKeepsEverySample) {
  const auto avg = average_positions(block_of(std::vector<Vec3>(50, Vec3(0, 9.8, 0))));
  EXPECT_EQ(avg[0].outliers_rejected, 0u);
  EXPECT_DOUBLE_EQ(avg[0].mean_g.y(), 1.0);
}

TEST(Averaging, RefusesAPositionWithoutTwoSamples) {
  EXPECT_THROW(average_positions(block_of({Vec3(0, 9.8, 0)})), std::runtime_error);
}

TEST(ApproachRule, FollowsModelMd) {
  // first from (0,0); larger |delta| decides; ties to alpha1; no move gives +1.
  const auto d =
      approach_directions({{-10, 5}, {-10, 20}, {-30, 20}, {-20, 30}, {-20, 30}, {0, 10}});
  EXPECT_EQ(d, (std::vector<int>{-1, +1, -1, +1, +1, +1}));
}

TEST(ApproachRule, RecordingColumnOverridesTheDerivedDirection) {
  Recording rec = block_of(std::vector<Vec3>(5, Vec3(0, 9.8, 0)), 0, 10, 0);
  for (auto& s : rec.samples) s.approach = -1;
  EXPECT_EQ(average_positions(rec)[0].approach, -1);
  for (auto& s : rec.samples) s.approach = 0;
  EXPECT_EQ(average_positions(rec)[0].approach, +1);
}
