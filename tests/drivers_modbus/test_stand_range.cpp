// Axis ranges: how a commanded angle is normalised and which way the axis turns.
#include <gtest/gtest.h>

#include <cmath>

#include "drivers/stand.hpp"

namespace standcal::drivers {
namespace {

AxisRange limited(double min_deg, double max_deg, CableWrap wrap = CableWrap::nearest) {
  return AxisRange{false, min_deg, max_deg, wrap};
}

double normalised(const AxisRange& range, double angle_deg, double current_deg = 0.0) {
  auto r = normalise_target_deg(range, angle_deg, current_deg);
  EXPECT_TRUE(r) << r.status().message;
  return r ? r.value() : 0.0;
}

TEST(AxisRangeNormalisation, ContinuousAxisFoldsIntoPlusMinus180) {
  const AxisRange continuous = AxisRange::continuous_axis();
  EXPECT_DOUBLE_EQ(normalised(continuous, 270.0), -90.0);
  EXPECT_DOUBLE_EQ(normalised(continuous, -190.0), 170.0);
  EXPECT_DOUBLE_EQ(normalised(continuous, 180.0), -180.0);
  EXPECT_DOUBLE_EQ(normalised(continuous, 725.0), 5.0);
}

TEST(AxisRangeNormalisation, LimitedPlusMinus180TakesEquivalentAngle) {
  const AxisRange range = limited(-180.0, 180.0);
  EXPECT_DOUBLE_EQ(normalised(range, 270.0), -90.0);
  EXPECT_DOUBLE_EQ(normalised(range, -300.0), 60.0);
  EXPECT_DOUBLE_EQ(normalised(range, 180.0, 170.0), 180.0);  // both edges equivalent: nearest wins
  EXPECT_DOUBLE_EQ(normalised(range, 180.0, -170.0), -180.0);
}

TEST(AxisRangeNormalisation, CableWrapPolicyChoosesAmongTurns) {
  const AxisRange wide = limited(-270.0, 270.0, CableWrap::nearest);
  EXPECT_DOUBLE_EQ(normalised(wide, 250.0, 200.0), 250.0);
  EXPECT_DOUBLE_EQ(normalised(wide, 250.0, -200.0), -110.0);
  const AxisRange centred = limited(0.0, 540.0, CableWrap::centred);
  EXPECT_DOUBLE_EQ(normalised(centred, 10.0, 0.0), 370.0);  // nearer the centre 270° than 10°
}

TEST(AxisRangeNormalisation, AngleWithNoEquivalentInsideIsALimitError) {
  auto r = normalise_target_deg(limited(-90.0, 90.0), 200.0, 0.0);
  ASSERT_FALSE(r);
  EXPECT_EQ(r.status().kind, ErrorKind::limit);
  EXPECT_NE(r.status().message.find("angle 200° is outside the range [-90°, 90°]"),
            std::string::npos)
      << r.status().message;
  // Just past an end, said as commanded: "angle 90.0000° is outside [..., 90.0000°]" before.
  const auto past = normalise_target_deg(limited(-90.0, 90.0), 90.00001, 0.0);
  ASSERT_FALSE(past);
  EXPECT_NE(past.status().message.find("angle 90.00001° is outside"), std::string::npos)
      << past.status().message;
  // The ends as configured: an end of 90.00004° was printed 90.0000°, so the angle past it
  // read as outside [..., 90.0000°].
  const auto past_fine_end = normalise_target_deg(limited(-90.0, 90.00004), 90.00005, 0.0);
  ASSERT_FALSE(past_fine_end);
  EXPECT_NE(
      past_fine_end.status().message.find("angle 90.00005° is outside the range [-90°, 90.00004°]"),
      std::string::npos)
      << past_fine_end.status().message;
  auto nan = normalise_target_deg(AxisRange::continuous_axis(),
                                  std::numeric_limits<double>::quiet_NaN(), 0.0);
  ASSERT_FALSE(nan);
  EXPECT_EQ(nan.status().kind, ErrorKind::invalid_argument);
}

TEST(AxisRangeNormalisation, AHugeAngleTakesItsExactEquivalent) {
  // 1e308 ≡ -64 (mod 360); std::remainder is exact where 1e308 - 360·floor(...) is not.
  const double equivalent = std::remainder(1e308, 360.0);
  ASSERT_NEAR(equivalent, -64.0, 1e-9);
  EXPECT_DOUBLE_EQ(normalised(AxisRange::continuous_axis(), 1e308), equivalent);
  EXPECT_DOUBLE_EQ(normalised(AxisRange::continuous_axis(), -1e308), -equivalent);
  EXPECT_DOUBLE_EQ(normalised(limited(-180.0, 180.0), 1e308), equivalent);
  EXPECT_DOUBLE_EQ(normalised(limited(0.0, 540.0, CableWrap::centred), 1e308), equivalent + 360.0);
  EXPECT_DOUBLE_EQ(path_target_deg(AxisRange::continuous_axis(), 1e308, 10.0).value(), equivalent);
}

TEST(AxisRangePath, ContinuousAxisTakesTheShorterWayFromItsCountedTurns) {
  const AxisRange continuous = AxisRange::continuous_axis();
  EXPECT_DOUBLE_EQ(path_target_deg(continuous, -170.0, 170.0).value(), 190.0);
  EXPECT_DOUBLE_EQ(path_target_deg(continuous, 0.0, 730.0).value(), 720.0);
  EXPECT_NEAR(path_target_deg(continuous, 90.0, -90.0 + 1e-6).value(), 90.0,
              1e-9);  // just under half a turn: forward
}

TEST(AxisRangePath, LimitedAxisGoesStraightInsideTheRange) {
  // From 170° to 270° ≡ −90° a ±180° axis must turn back through 0°, never across ±180°.
  EXPECT_DOUBLE_EQ(path_target_deg(limited(-180.0, 180.0), 270.0, 170.0).value(), -90.0);
}

TEST(AxisRangeReading, ErrorsAndReadingsWrapOnlyOnContinuousAxes) {
  const AxisRange continuous = AxisRange::continuous_axis();
  EXPECT_DOUBLE_EQ(normalise_reading_deg(continuous, 370.0), 10.0);
  EXPECT_DOUBLE_EQ(angle_error_deg(continuous, 179.0, -179.0), -2.0);
  EXPECT_DOUBLE_EQ(normalise_reading_deg(limited(-270, 270), 250.0), 250.0);
  EXPECT_DOUBLE_EQ(angle_error_deg(limited(-270, 270), 179.0, -179.0), 358.0);
}

}  // namespace
}  // namespace standcal::drivers
