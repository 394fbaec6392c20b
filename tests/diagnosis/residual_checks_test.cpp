// The honesty checks on residuals (calib/diagnosis/residual_checks): white residuals pass
// at about their nominal false-alarm rate; a step, a pattern along an angle and a
// half-dependent term are caught and located.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "calib/diagnosis/residual_checks.hpp"

namespace standcal::diagnosis {
namespace {

// 16 poses visited forward then in reverse (like diagnostic32), 12 s apart, 3 outputs.
std::vector<ResidualSample> white_residuals(std::mt19937_64& rng) {
  std::normal_distribution<double> noise(0, 1);
  std::vector<ResidualSample> out;
  for (int k = 0; k < 32; ++k) {
    const int pose = k < 16 ? k : 31 - k;
    const double a1 = 22.5 * pose, a2 = 45.0 * (pose % 8);
    const double r1 = a1 * M_PI / 180, r2 = a2 * M_PI / 180;
    const Vec3 up(std::sin(r1), std::cos(r1) * std::cos(r2), std::cos(r1) * std::sin(r2));
    for (const char* c : {"x", "y", "z"})
      out.push_back({k, k + 1, c, 6.0 + 12.0 * k, a1, a2, up, noise(rng)});
  }
  return out;
}

TEST(ResidualChecks, WhiteResidualsPassAtTheirNominalRate) {
  std::mt19937_64 rng(15);
  int flagged = 0;
  constexpr int kTrials = 400;
  for (int i = 0; i < kTrials; ++i)
    flagged += whiteness_tests(white_residuals(rng), 1e-2).white ? 0 : 1;
  // Family alpha 1 % (Bonferroni, so at most 1 % and usually less): 400 trials, 4 expected
  // at most; 12 would be 4 sigma of a binomial(400, 0.01) above that.
  EXPECT_LE(flagged, 12);
  const WhitenessResult one = whiteness_tests(white_residuals(rng));
  EXPECT_EQ(one.tests.size(), 24u);  // 3 outputs x (6 serial orderings + step + outlier)
}

TEST(ResidualChecks, AStepMidRunIsCaughtAndLocatedInTime) {
  std::mt19937_64 rng(3);
  std::vector<ResidualSample> rs = white_residuals(rng);
  for (ResidualSample& r : rs)
    if (r.component == "z")
      r.r += r.t_s > 192 ? 1.5 : -1.5;  // residual of a jump a drift did not absorb
  const WhitenessResult w = whiteness_tests(rs);
  ASSERT_FALSE(w.white);
  const WhitenessTest& worst = w.tests[static_cast<std::size_t>(w.worst)];
  EXPECT_EQ(worst.component, "z");
  EXPECT_EQ(worst.against, "time");
  EXPECT_NE(whiteness_words(worst).find("the z output"), std::string::npos);
}

TEST(ResidualChecks, APatternAlongAGravityComponentIsCaught) {
  std::mt19937_64 rng(4);
  std::vector<ResidualSample> rs = white_residuals(rng);
  // What a K3 fit leaves of a |u|^3-shaped effect: positive at the poles, negative between.
  for (ResidualSample& r : rs)
    if (r.component == "x") r.r += 8 * (std::abs(r.up[0]) - 0.55);
  const WhitenessResult w = whiteness_tests(rs, 1e-2);  // 32 residuals: a 4-sigma pattern needs it
  ASSERT_FALSE(w.white);
  EXPECT_EQ(w.tests[static_cast<std::size_t>(w.worst)].component, "x");
  // The serial test that sees it best orders the residuals by an angle or gravity component.
  const WhitenessTest* best_serial = nullptr;
  for (const WhitenessTest& t : w.tests)
    if (t.test == "serial" && (!best_serial || t.p < best_serial->p)) best_serial = &t;
  ASSERT_NE(best_serial, nullptr);
  EXPECT_NE(best_serial->against, "time");
}

TEST(ResidualChecks, OneSuddenEventIsAnOutlier) {
  std::mt19937_64 rng(6);
  std::vector<ResidualSample> rs = white_residuals(rng);
  rs[3 * 20 + 1].r = 6.5;  // y at the 21st position: what a jump leaves as one innovation
  const WhitenessResult w = whiteness_tests(rs);
  ASSERT_FALSE(w.white);
  const WhitenessTest& worst = w.tests[static_cast<std::size_t>(w.worst)];
  EXPECT_EQ(worst.test, "outlier");
  EXPECT_EQ(worst.component, "y");
  ASSERT_EQ(worst.positions.size(), 1u);
  EXPECT_EQ(worst.positions[0], 21);
}

TEST(ResidualChecks, TooFewResidualsAreNotTested) {
  std::mt19937_64 rng(5);
  std::vector<ResidualSample> rs = white_residuals(rng);
  rs.resize(7);  // 7 residuals over 3 outputs
  const WhitenessResult w = whiteness_tests(rs);
  EXPECT_TRUE(w.tests.empty());
  EXPECT_TRUE(w.white);
  EXPECT_EQ(w.worst, -1);
}

TEST(ResidualChecks, HalfStabilityComparesEachHalfWithTheWhole) {
  // A drift that only stands in for a jump: the whole run says 40 +- 4, each half ~0 +- 8.
  HalfStability jump{"bias_drift", "z", "ug/h", 40, 4, 1, 8, -2, 8, 0, true};
  judge_half_stability(jump, 3);
  EXPECT_FALSE(jump.stable);
  EXPECT_NEAR(std::abs(jump.z), 42 / std::sqrt(64.0 - 16.0), 1e-9);
  HalfStability drift{"bias_drift", "z", "ug/h", 40, 4, 45, 8, 36, 8, 0, true};
  judge_half_stability(drift, 3);
  EXPECT_TRUE(drift.stable);
  // A half that cannot fit the term (NaN) does not make the term unstable.
  HalfStability half_blind{"bias_drift", "z", "ug/h", 40, 4,   std::nan(""),
                           std::nan(""), 41,  6,      0,  true};
  judge_half_stability(half_blind, 3);
  EXPECT_TRUE(half_blind.stable);
}

}  // namespace
}  // namespace standcal::diagnosis
