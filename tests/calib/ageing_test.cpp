// The one ageing rule (calib/ageing.hpp).
#include "calib/ageing.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace standcal {
namespace {

TEST(AgeingRule, SuccessiveObservedCalibrationsAreComparedAndFlaggedBeyondKSigma) {
  const std::vector<ParameterObservation> h{
      {"r1", 10, 100.0, 3.0},
      {"r2", 40, std::nullopt, std::nullopt},  // not observable in that programme: skipped
      {"r3", 70, 109.0, 4.0},                  // 9 against 2 · 5 = 10: not flagged
      {"r4", 100, 120.0, 3.0},                 // 11 against 2 · 5 = 10: flagged
      {"r5", 130, 121.0, std::nullopt},        // a value without σ cannot be judged: skipped
  };
  const std::vector<ParameterChange> c = parameter_changes(h, 2.0);
  ASSERT_EQ(c.size(), 2u);
  EXPECT_EQ(c[0].from_run_id, "r1");
  EXPECT_EQ(c[0].to_run_id, "r3");
  EXPECT_DOUBLE_EQ(c[0].delta, 9.0);
  EXPECT_DOUBLE_EQ(c[0].combined_sigma, 5.0);
  EXPECT_DOUBLE_EQ(c[0].days, 60.0);
  EXPECT_FALSE(c[0].ageing);
  EXPECT_EQ(c[1].from_run_id, "r3");
  EXPECT_DOUBLE_EQ(c[1].delta, 11.0);
  EXPECT_TRUE(c[1].ageing);
  // The coverage factor is the caller's.
  EXPECT_FALSE(parameter_changes(h, 3.0)[1].ageing);
}

TEST(AgeingRule, FewerThanTwoObservationsHaveNoChange) {
  EXPECT_TRUE(parameter_changes({}, 2.0).empty());
  const std::vector<ParameterObservation> one{{"r1", 0, 1.0, 1.0}};
  EXPECT_TRUE(parameter_changes(one, 2.0).empty());
}

}  // namespace
}  // namespace standcal
