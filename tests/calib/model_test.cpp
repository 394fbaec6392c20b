// The conventions of model.md, checked number by number.
#include <gtest/gtest.h>

#include "calib/model.hpp"
#include "calib/units.hpp"

using namespace standcal;

TEST(UpVector, MatchesTheChecksOfModelMd) {
  const Vec3 a = up_vector(30 * kDegToRad, 0);
  EXPECT_NEAR(a.x(), std::sin(30 * kDegToRad), 1e-15);
  EXPECT_NEAR(a.y(), std::cos(30 * kDegToRad), 1e-15);
  EXPECT_NEAR(a.z(), 0, 1e-15);
  const Vec3 b = up_vector(0, 40 * kDegToRad);
  EXPECT_NEAR(b.y(), std::cos(40 * kDegToRad), 1e-15);
  EXPECT_NEAR(b.z(), std::sin(40 * kDegToRad), 1e-15);
  const Vec3 c = up_vector(45 * kDegToRad, 90 * kDegToRad);
  EXPECT_NEAR(c.x(), 0.70710678, 1e-8);
  EXPECT_NEAR(c.y(), 0, 1e-15);
  EXPECT_NEAR(c.z(), 0.70710678, 1e-8);
}

TEST(UpVector, EqualsRotationsAppliedToVerticalForAnyAngles) {
  for (double a1 : {-170.0, -33.0, 0.0, 72.0, 200.0})
    for (double a2 : {-90.0, 0.0, 57.5, 122.5, 270.0}) {
      const Vec3 direct = C2(a2 * kDegToRad) * C1(a1 * kDegToRad) * Vec3::UnitY();
      EXPECT_LT((direct - up_vector(a1 * kDegToRad, a2 * kDegToRad)).norm(), 1e-14);
    }
}

TEST(HardwareSignCheck, ZUpAtInnerPlus90AndXUpAtOuterPlus90) {
  const UnitErrors ideal;
  EXPECT_NEAR(unit_output_g(ideal, true_up_vector(0, kPi / 2, Mount::x, {})).z(), 1.0, 1e-15);
  EXPECT_NEAR(unit_output_g(ideal, true_up_vector(kPi / 2, 0, Mount::x, {})).x(), 1.0, 1e-15);
  EXPECT_NEAR(unit_output_g(ideal, true_up_vector(0, 0, Mount::x, {})).y(), 1.0, 1e-15);
}

TEST(Mounts, PermuteTheTableAxesAsModelMdSays) {
  const Vec3 uT = up_vector_table(0.3, 1.1);
  const Vec3 y = up_vector(0.3, 1.1, Mount::y);
  const Vec3 z = up_vector(0.3, 1.1, Mount::z);
  EXPECT_EQ(y, Vec3(uT[2], uT[0], uT[1]));
  EXPECT_EQ(z, Vec3(uT[1], uT[2], uT[0]));
}

TEST(RotationExp, IsExactRotationAndMatchesFirstOrderForSmallAngles) {
  const Vec3 theta(0.3, -0.2, 0.5);
  const Mat3 R = rotation_exp(theta);
  EXPECT_LT((R * R.transpose() - Mat3::Identity()).norm(), 1e-14);
  EXPECT_NEAR(R.determinant(), 1.0, 1e-14);
  EXPECT_LT((R * theta - theta).norm(), 1e-14);  // the axis is fixed
  const Vec3 small(1e-6, 2e-6, -3e-6);
  EXPECT_LT((rotation_exp(small) - (Mat3::Identity() - cross_matrix(small))).norm(), 1e-11);
  // A frame rotation about z by +a is C1(a).
  EXPECT_LT((rotation_exp(Vec3(0, 0, 0.7)) - C1(0.7)).norm(), 1e-14);
  // C2 is a frame rotation by -a about x.
  EXPECT_LT((rotation_exp(Vec3(-0.7, 0, 0)) - C2(0.7)).norm(), 1e-14);
}

TEST(InvariantMeasurement, IsLinearInTheNineParametersToFirstOrder) {
  UnitErrors unit;
  unit.bias_g = Vec3(50, -20, 80) * kUg;
  unit.scale = Vec3(200, -100, 300) * kPpm;
  unit.gamma_rad << 0, 10, 20, 5, 0, -30, 15, 25, 0;
  unit.gamma_rad *= kArcsecToRad;
  Eigen::Matrix<double, 9, 1> X;
  X << unit.bias_g, unit.scale, unit.gamma_pair_sums_rad();
  for (double a1 : {0.0, 45.0, 200.0})
    for (double a2 : {0.0, 57.5, 300.0}) {
      const Vec3 u = up_vector(a1 * kDegToRad, a2 * kDegToRad);
      const double exact = delta_J_L(u, unit_output_g(unit, u));
      // What the linear form drops is second order: products dk*gamma <= 3e-4 * 1.5e-4.
      EXPECT_NEAR(exact, (invariant_regressor(u) * X)(0), 5e-8);
    }
}

TEST(InvariantMeasurement, IsBlindToSmallStandErrorsToFirstOrder) {
  StandErrors stand;
  stand.levelling_x_rad = 60 * kArcsecToRad;
  stand.levelling_z_rad = -60 * kArcsecToRad;
  stand.alpha1_offset_rad = 20 * kArcsecToRad;
  stand.skew_y_rad = 20 * kArcsecToRad;
  stand.mounting_rad[0] = Vec3(120, -120, 120) * kArcsecToRad;
  const UnitErrors ideal;
  for (double a1 : {10.0, 100.0})
    for (double a2 : {20.0, 250.0}) {
      const Vec3 u = up_vector(a1 * kDegToRad, a2 * kDegToRad);
      const Vec3 J =
          unit_output_g(ideal, true_up_vector(a1 * kDegToRad, a2 * kDegToRad, Mount::x, stand));
      EXPECT_LT(std::abs(delta_J_L(u, J)), 2e-6);  // second order of ~6e-4 rad
      EXPECT_GT((J - u).norm(), 1e-4);             // while the vector itself moves by ~1e-3
    }
}
