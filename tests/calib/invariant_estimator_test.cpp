// The paper's invariant method: what it promises (invariance to small stand errors,
// nine unknowns from nine positions) and where it silently fails (large mounting).
#include <gtest/gtest.h>

#include <cmath>

#include "tests/calib/test_support.hpp"

using namespace standcal;
using namespace standcal::test;

namespace {

// Stand errors of the issue: levelling 1', angle sensors 20", skew 20", mounting 2'.
StandErrors realistic_stand() {
  StandErrors s;
  s.levelling_x_rad = 60 * kArcsecToRad;
  s.levelling_z_rad = -60 * kArcsecToRad;
  s.alpha1_offset_rad = 20 * kArcsecToRad;
  s.alpha2_offset_rad = -20 * kArcsecToRad;
  s.skew_y_rad = 20 * kArcsecToRad;
  s.skew_z_rad = -20 * kArcsecToRad;
  s.mounting_rad[0] = Vec3(120, -120, 120) * kArcsecToRad;
  return s;
}

void expect_within_report_units(const FitResult& fit, const Eigen::Matrix<double, 9, 1>& truth,
                                double tol_ug, double tol_ppm, double tol_arcsec) {
  const double tol[3] = {tol_ug * kUg, tol_ppm * kPpm, tol_arcsec * kArcsecToRad};
  for (int j = 0; j < 9; ++j) {
    ASSERT_TRUE(fit.unit[static_cast<std::size_t>(j)].value)
        << kUnitParameterNames[static_cast<std::size_t>(j)];
    EXPECT_NEAR(*fit.unit[static_cast<std::size_t>(j)].value, truth[j], tol[j / 3])
        << kUnitParameterNames[static_cast<std::size_t>(j)];
  }
}

}  // namespace

TEST(InvariantJoint, IsInvariantToRealisticStandErrorsWithoutNoise) {
  TruthModel truth = noise_free(default_truth());
  truth.stand = realistic_stand();
  for (const Program& program : {paper9(), paper9(17.0, 1), redundant18()}) {
    const FitResult fit = fit_invariant_joint(simulate_averages(program, truth));
    SCOPED_TRACE(program.name);
    expect_within_report_units(fit, true_parameters(truth.unit), 1.0, 1.0, 1.0);
  }
}

TEST(InvariantJoint, PaperProgrammeHasNineUnknownsFromNinePositions) {
  const FitResult fit = fit_invariant_joint(simulate_averages(paper9(), default_truth()));
  EXPECT_EQ(fit.positions, 9);
  EXPECT_EQ(fit.parameters_estimated, 9);
  EXPECT_EQ(fit.redundancy, 0);
  EXPECT_TRUE(std::isnan(fit.chi2_dof));
  ASSERT_FALSE(fit.notes.empty());
  EXPECT_NE(fit.notes[0].find("cannot reveal a wrong model"), std::string::npos);
  for (const auto& p : fit.unit) EXPECT_TRUE(p.value && p.sigma && *p.sigma > 0);
}

TEST(InvariantJoint, SequentialAndJointAgreeOnNoiseFreeData) {
  const auto averages = simulate_averages(paper9(), noise_free(default_truth()));
  const FitResult joint = fit_invariant_joint(averages);
  const FitResult sequential = fit_paper_sequential(averages);
  for (std::size_t j = 0; j < 9; ++j)
    EXPECT_NEAR(*joint.unit[j].value, *sequential.unit[j].value, 1e-12) << kUnitParameterNames[j];
}

TEST(InvariantJoint, SequentialUncertaintiesMatchJointOnTheSquareProgramme) {
  // Nine equations, nine unknowns: both methods solve the same system, so the
  // propagated covariances must agree too.
  const auto averages = simulate_averages(paper9(), default_truth(), 3, 20);
  const FitResult joint = fit_invariant_joint(averages);
  const FitResult sequential = fit_paper_sequential(averages);
  for (std::size_t j = 0; j < 9; ++j)
    EXPECT_NEAR(*joint.unit[j].sigma, *sequential.unit[j].sigma, 1e-6 * *joint.unit[j].sigma);
}

TEST(InvariantJoint, ClassicProgrammeReportsGammaUnobservableNotNumbers) {
  const FitResult fit = fit_invariant_joint(simulate_averages(classic24(), default_truth()));
  for (int j : {kGamma12, kGamma13, kGamma23}) {
    const ParameterEstimate& p = fit.unit[static_cast<std::size_t>(j)];
    EXPECT_FALSE(p.value);
    EXPECT_FALSE(p.sigma);
    EXPECT_NE(p.unobservable_reason.find("zero at every position"), std::string::npos);
    EXPECT_TRUE(std::isnan(fit.correlation(j, j)));
  }
  EXPECT_EQ(fit.parameters_estimated, 6);
  EXPECT_EQ(fit.redundancy, 18);
  const auto truth = true_parameters(default_truth().unit);
  for (int j = 0; j < 6; ++j)
    EXPECT_NEAR(*fit.unit[static_cast<std::size_t>(j)].value, truth[j],
                5 * *fit.unit[static_cast<std::size_t>(j)].sigma);
}

TEST(InvariantJoint, NamesCombinationsWhenPositionsAreTooFew) {
  // Five positions at alpha2 = 0 see only x and y: z terms have zero regressors, and
  // five unknowns remain for five positions.
  const Program flat = program_of("flat5", {{0, 0}, {72, 0}, {144, 0}, {216, 0}, {288, 0}});
  const FitResult fit = fit_invariant_joint(simulate_averages(flat, default_truth()));
  for (int j : {kBiasZ, kScaleZ, kGamma13, kGamma23})
    EXPECT_FALSE(fit.unit[static_cast<std::size_t>(j)].value)
        << kUnitParameterNames[static_cast<std::size_t>(j)];
  EXPECT_EQ(fit.parameters_estimated, 5);
}

TEST(PaperSequential, RefusesProgrammesWithoutThePaperStructure) {
  const Program two = program_of("two", {{0, 0}, {90, 0}});
  EXPECT_THROW(fit_paper_sequential(simulate_averages(two, default_truth())), std::runtime_error);
  EXPECT_THROW(fit_paper_sequential(simulate_averages(classic24(), default_truth())),
               std::runtime_error);
}

// model.md: a mounting rotation phi about n makes u^T R u - 1 = -(1 - cos phi)(1 - (n.u)^2),
// a quadratic form the scale and gamma terms absorb exactly: dk_i is off by
// -(1 - cos phi)(1 - n_i^2), gamma_ij by 2 (1 - cos phi) n_i n_j, and the fit stays perfect.
class SilentMountingBias : public ::testing::TestWithParam<double> {};

TEST_P(SilentMountingBias, MatchesTheClosedFormAndLeavesAPerfectFit) {
  const double phi_rad = GetParam() * kArcminToRad;
  const Vec3 n = Vec3(1, -2, 2).normalized();
  TruthModel truth = noise_free(TruthModel{});
  truth.unit.bias_g = Vec3(40, -25, 60) * kUg;  // biases do not couple with the rotation
  truth.stand.mounting_rad[0] = phi_rad * n;
  const FitResult fit = fit_invariant_joint(simulate_averages(redundant18(), truth));

  const double c = 1.0 - std::cos(phi_rad);
  const Vec3 expected_dk(-c * (1 - n.x() * n.x()), -c * (1 - n.y() * n.y()),
                         -c * (1 - n.z() * n.z()));
  const Vec3 expected_gamma(2 * c * n.x() * n.y(), 2 * c * n.x() * n.z(), 2 * c * n.y() * n.z());
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(*fit.unit[static_cast<std::size_t>(kScaleX + i)].value, expected_dk[i], 0.1 * kPpm);
    EXPECT_NEAR(*fit.unit[static_cast<std::size_t>(kGamma12 + i)].value, expected_gamma[i],
                0.1 * kPpm);
    EXPECT_NEAR(*fit.unit[static_cast<std::size_t>(kBiasX + i)].value, truth.unit.bias_g[i],
                0.01 * kUg);
  }
  EXPECT_LT(fit.residual_rms_g, 1e-3 * kUg);  // the fit is perfect: nothing shows the error
  // ... and the error is not small: at 2 deg it is ~600 ppm in total.
  if (GetParam() >= 120) {
    EXPECT_GT(expected_dk.cwiseAbs().maxCoeff(), 300 * kPpm);
  }
}

INSTANTIATE_TEST_SUITE_P(TenArcminAndTwoDegrees, SilentMountingBias,
                         ::testing::Values(10.0, 120.0));
