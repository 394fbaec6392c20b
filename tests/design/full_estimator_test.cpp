// The full-vector estimator: exact recovery, the 2-degree mounting case against the
// invariant method, and the observability analysis naming what a programme cannot see.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <string>

#include "calib/design.hpp"
#include "calib/full_estimator.hpp"
#include "calib/identifiability.hpp"
#include "calib/invariant_estimator.hpp"
#include "calib/parameters.hpp"
#include "tests/design/synthetic.hpp"

namespace standcal {
namespace {

using testing::synthetic_averages;
using testing::typical_unit;

// Stand errors well outside what the invariant method tolerates (issue 3).
StandErrors rough_stand(double mounting_deg) {
  StandErrors s;
  s.levelling_x_rad = 30 * kArcminToRad;
  s.levelling_z_rad = -30 * kArcminToRad;
  s.alpha1_offset_rad = 20 * kArcsecToRad;
  s.alpha2_offset_rad = -20 * kArcsecToRad;
  s.skew_y_rad = 20 * kArcsecToRad;
  s.skew_z_rad = 15 * kArcsecToRad;
  // A mounting rotation of `mounting_deg` about an oblique axis, the same for every mount
  // (the unit sits in one rigid fixture).
  const Vec3 psi = Vec3(1, -2, 2).normalized() * mounting_deg * kDegToRad;
  s.mounting_rad = {psi, psi, psi};
  return s;
}

std::array<double, kUnitParameterCount> truth_values(const UnitErrors& u) {
  const Vec3 g = u.gamma_pair_sums_rad();
  return {u.bias_g.x(), u.bias_g.y(), u.bias_g.z(), u.scale.x(), u.scale.y(),
          u.scale.z(),  g.x(),        g.y(),        g.z()};
}

bool has_note_containing(const FitResult& fit, const std::string& text) {
  return std::any_of(fit.notes.begin(), fit.notes.end(),
                     [&](const std::string& n) { return n.find(text) != std::string::npos; });
}

const StandEstimate* stand_entry(const FitResult& fit, const std::string& name) {
  for (const auto& e : fit.stand)
    if (e.name == name) return &e;
  return nullptr;
}

TEST(FullEstimator, RecoversUnitAndStandExactlyWithoutNoise) {
  const UnitErrors unit = typical_unit();
  const StandErrors stand = rough_stand(2.0);
  for (const Program& program : {paper9(), classic24()}) {
    const FitResult fit = fit_full_vector(synthetic_averages(poses_of(program), unit, stand, 0.0));
    const auto truth = truth_values(unit);
    for (int i = 0; i < kUnitParameterCount; ++i) {
      ASSERT_TRUE(fit.unit[i].value.has_value()) << program.name << " " << kUnitParameterNames[i];
      EXPECT_NEAR(*fit.unit[i].value * report_scale(i), truth[i] * report_scale(i), 1e-3)
          << program.name << " " << kUnitParameterNames[i];
    }
    EXPECT_LT(fit.residual_rms_g, 1e-9) << program.name;
  }
}

TEST(FullEstimator, StandHealthNamesTheRotationAboutTheOuterAxis) {
  const StandErrors stand = rough_stand(0.5);
  const FitResult fit =
      fit_full_vector(synthetic_averages(poses_of(paper9()), typical_unit(), stand, 0.0));
  // Levelling about z_S, the skew about the outer axis and the alpha1 zero are one rotation.
  const StandEstimate* outer = stand_entry(fit, "alpha1_offset + levelling_z + skew_z");
  ASSERT_NE(outer, nullptr);
  const double expected_arcsec =
      (stand.alpha1_offset_rad + stand.levelling_z_rad + stand.skew_z_rad) * kRadToArcsec;
  // Equal to first order; the 30' levelling leaves a second-order remainder of ~0.05".
  EXPECT_NEAR(outer->value, expected_arcsec, 0.2);
  EXPECT_EQ(outer->unit, "arcsec");
  const StandEstimate* level_x = stand_entry(fit, "levelling_x");
  ASSERT_NE(level_x, nullptr);
  EXPECT_NEAR(level_x->value, stand.levelling_x_rad * kRadToArcsec, 0.2);
  const StandEstimate* skew_y = stand_entry(fit, "skew_y");
  ASSERT_NE(skew_y, nullptr);
  EXPECT_NEAR(skew_y->value, stand.skew_y_rad * kRadToArcsec, 0.01);
}

// Issue 3: with mounting 2 deg and levelling 30' the nine unit parameters come out within
// their reported 3 sigma, while the invariant estimator on the same data is far off.
TEST(FullEstimator, TwoDegreeMountingWithinThreeSigmaWhereInvariantFails) {
  const UnitErrors unit = typical_unit();
  const StandErrors stand = rough_stand(2.0);
  const auto truth = truth_values(unit);
  const double sigma_g = 1.0 * kUg;  // 10 ug/rtHz, 100 s dwell
  for (const Program& program : {paper9(), classic24()}) {
    std::mt19937_64 rng(20261121);
    const auto averages = synthetic_averages(poses_of(program), unit, stand, sigma_g, &rng);
    const FitResult full = fit_full_vector(averages);
    const FitResult invariant = fit_invariant_joint(averages);
    double worst_invariant_in_sigma = 0;
    for (int i = 0; i < kUnitParameterCount; ++i) {
      ASSERT_TRUE(full.unit[i].value && full.unit[i].sigma)
          << program.name << " " << kUnitParameterNames[i];
      const double err = *full.unit[i].value - truth[i];
      EXPECT_LT(std::abs(err), 3 * *full.unit[i].sigma)
          << program.name << " " << kUnitParameterNames[i] << ": error " << err * report_scale(i)
          << " " << kUnitParameterUnits[i] << ", sigma " << *full.unit[i].sigma * report_scale(i);
      if (invariant.unit[i].value && invariant.unit[i].sigma)
        worst_invariant_in_sigma =
            std::max(worst_invariant_in_sigma,
                     std::abs(*invariant.unit[i].value - truth[i]) / *full.unit[i].sigma);
    }
    // model.md: a 2 deg mounting moves delta k by up to ~600 ppm; sigma here is ~1 ppm.
    EXPECT_GT(worst_invariant_in_sigma, 100.0) << program.name;
  }
}

TEST(FullEstimator, PaperProgramNamesWhatItCannotSeparate) {
  const FitResult fit =
      fit_full_vector(synthetic_averages(poses_of(paper9()), typical_unit(), StandErrors{}, 0.0));
  EXPECT_TRUE(has_note_containing(fit,
                                  "the antisymmetric part of the non-orthogonality x–y "
                                  "(gamma_antisymmetric_xy) is indistinguishable "
                                  "from the mounting misalignment about z"));
  EXPECT_TRUE(has_note_containing(
      fit, "(alpha2_offset) is indistinguishable from the mounting misalignment about x"));
  EXPECT_TRUE(has_note_containing(
      fit, "(levelling_z) is indistinguishable from the zero offset of the outer-axis"));
  for (int i = 0; i < kUnitParameterCount; ++i) EXPECT_TRUE(fit.unit[i].value.has_value()) << i;
  EXPECT_EQ(fit.redundancy, 27 - fit.parameters_estimated);
}

TEST(FullEstimator, ClassicProgramNeedsARigidFixtureForGamma) {
  const auto averages =
      synthetic_averages(poses_of(classic24()), typical_unit(), StandErrors{}, 0.0);
  const FitResult rigid = fit_full_vector(averages);
  for (int i = 0; i < kUnitParameterCount; ++i) EXPECT_TRUE(rigid.unit[i].value.has_value()) << i;
  // With the inner axis vertical, turning it is a rotation about gravity: no effect.
  EXPECT_TRUE(
      has_note_containing(rigid, "the zero offset of the inner-axis angle sensor has no effect"));

  FullFitOptions per_mount;
  per_mount.mounting = MountingModel::per_mount;
  const FitResult loose = fit_full_vector(averages, per_mount);
  for (int i = 0; i < kUnitParameterCount; ++i) {
    const bool is_gamma = i >= kGamma12;
    EXPECT_EQ(loose.unit[i].value.has_value(), !is_gamma) << kUnitParameterNames[i];
    if (is_gamma) {
      EXPECT_NE(loose.unit[i].unobservable_reason.find("mounting misalignment"), std::string::npos);
    }
  }
  EXPECT_TRUE(has_note_containing(
      loose, "(mount_y_psi_z) is indistinguishable from the non-orthogonality x–y"));
  // Per-mount misalignments appear in the stand report (mount z's horizontal ones are
  // folded into those of x and y and into gamma, about its vertical axis it has no effect).
  for (const std::string mount : {"x", "y"}) {
    EXPECT_TRUE(std::any_of(loose.stand.begin(), loose.stand.end(), [&](const StandEstimate& e) {
      return e.name.rfind("mount_" + mount + "_psi_", 0) == 0;
    })) << mount;
  }
}

}  // namespace
}  // namespace standcal

namespace standcal {
namespace {

TEST(FullEstimator, TooFewPositionsGiveReasonsNotNumbers) {
  auto poses = poses_of(paper9());
  poses.resize(6);
  const FitResult fit = fit_full_vector(
      testing::synthetic_averages(poses, testing::typical_unit(), StandErrors{}, 1e-6));
  int reported = 0;
  for (int i = 0; i < kUnitParameterCount; ++i) {
    if (fit.unit[i].value) {
      ++reported;
      EXPECT_TRUE(std::isfinite(*fit.unit[i].value));
    } else {
      EXPECT_FALSE(fit.unit[i].unobservable_reason.empty()) << kUnitParameterNames[i];
    }
  }
  EXPECT_LT(reported, kUnitParameterCount);
  EXPECT_GT(reported, 0);
}

// Degenerate input is refused before any decomposition, with the counts (issue 14).
TEST(FullEstimator, NothingToFitIsRefusedWithTheCounts) {
  auto poses = poses_of(paper9());
  poses.resize(3);
  try {
    (void)fit_full_vector(
        testing::synthetic_averages(poses, testing::typical_unit(), StandErrors{}, 1e-6));
    FAIL() << "three positions along one circle were fitted";
  } catch (const CannotFit& e) {
    EXPECT_NE(std::string(e.what()).find("cannot fit (full vector): 3 positions for"),
              std::string::npos)
        << e.what();
  }
  EXPECT_THROW(fit_full_vector({}), CannotFit);
}

}  // namespace
}  // namespace standcal
