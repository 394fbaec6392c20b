// Honest uncertainties: over many seeded simulated runs, (estimate - truth) / sigma must
// have zero mean and unit variance for every parameter.
#include <gtest/gtest.h>

#include <cmath>

#include "tests/calib/test_support.hpp"
#include "tests/support/statistical.hpp"

using namespace standcal;
using namespace standcal::test;

namespace {

constexpr int kRuns = 400;
// Sample variance of 400 unit normals has sd sqrt(2/399) = 0.071: +-0.25 is 3.5 sd.
constexpr double kVarianceTolerance = 0.25;
// Mean of 400 unit normals has sd 0.05: +-0.2 is 4 sd.
constexpr double kMeanTolerance = 0.2;

struct NormalisedErrors {
  Eigen::Matrix<double, 9, 1> sum = Eigen::Matrix<double, 9, 1>::Zero();
  Eigen::Matrix<double, 9, 1> sum_sq = Eigen::Matrix<double, 9, 1>::Zero();
  double chi2_sum = 0;
  double dof_sum = 0;  // the fits' redundancy, less any noise parameters they estimated
  int runs = 0;
};

NormalisedErrors run_monte_carlo(const Program& program,
                                 FitResult (*fit)(const std::vector<PositionAverage>&)) {
  const TruthModel truth = default_truth();
  const auto x_true = true_parameters(truth.unit);
  NormalisedErrors e;
  for (int run = 0; run < kRuns; ++run) {
    const FitResult r =
        fit(simulate_averages(program, truth, 1000 + static_cast<std::uint64_t>(run), 4));
    for (int j = 0; j < 9; ++j) {
      const auto& p = r.unit[static_cast<std::size_t>(j)];
      const double z = (*p.value - x_true[j]) / *p.sigma;
      e.sum[j] += z;
      e.sum_sq[j] += z * z;
    }
    e.chi2_sum += r.chi2;
    e.dof_sum += r.redundancy;
    ++e.runs;
  }
  return e;
}

void expect_unit_normal(const NormalisedErrors& e) {
  for (int j = 0; j < 9; ++j) {
    const double mean = e.sum[j] / e.runs;
    const double var = (e.sum_sq[j] - e.runs * mean * mean) / (e.runs - 1);
    EXPECT_NEAR(mean, 0.0, kMeanTolerance) << kUnitParameterNames[static_cast<std::size_t>(j)];
    EXPECT_NEAR(var, 1.0, kVarianceTolerance) << kUnitParameterNames[static_cast<std::size_t>(j)];
  }
}

}  // namespace

TEST(MonteCarlo, JointSigmasAreHonestOnThePaperProgramme) {
  STANDCAL_STATISTICAL_TEST();
  expect_unit_normal(run_monte_carlo(paper9(), fit_invariant_joint));
}

TEST(MonteCarlo, SequentialSigmasAreHonestOnThePaperProgramme) {
  STANDCAL_STATISTICAL_TEST();
  expect_unit_normal(run_monte_carlo(paper9(), fit_paper_sequential));
}

TEST(MonteCarlo, JointSigmasAndChi2AreHonestWithRedundancy) {
  STANDCAL_STATISTICAL_TEST();
  const NormalisedErrors e = run_monte_carlo(redundant18(), fit_invariant_joint);
  expect_unit_normal(e);
  // chi2 of 9 dof averages 9; over 400 runs the mean has sd sqrt(18/400) = 0.21. A fit that
  // weighted for a wander estimated from its own residuals tests on fewer degrees of freedom.
  EXPECT_NEAR(e.chi2_sum / e.runs, e.dof_sum / e.runs, 1.0);
  EXPECT_GT(e.dof_sum / e.runs, 8.0) << "white noise is mostly taken for white";
}
