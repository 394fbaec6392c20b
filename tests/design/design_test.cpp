// Experiment design: the optimiser rediscovers the paper's angles from the D-criterion,
// predicted sigmas match the estimators' Monte-Carlo scatter, dwell allocation and bench time.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "calib/design.hpp"
#include "calib/full_estimator.hpp"
#include "calib/invariant_estimator.hpp"
#include "tests/design/synthetic.hpp"
#include "tests/support/statistical.hpp"

namespace standcal {
namespace {

double wrap360(double a) {
  const double w = std::fmod(a, 360.0);
  return w < 0 ? w + 360.0 : w;
}

bool matches_set(std::vector<double> got, std::vector<double> want, double tol_deg) {
  std::sort(got.begin(), got.end());
  std::sort(want.begin(), want.end());
  for (std::size_t i = 0; i < got.size(); ++i)
    if (std::abs(got[i] - want[i]) > tol_deg) return false;
  return true;
}

TEST(DesignOptimize, PaperStructureReproducesThePaperAnglesFromTheCriterion) {
  OptimizeOptions options;
  options.paper_structure = true;
  const OptimizedProgram best = optimize_program(options);
  ASSERT_EQ(best.program.positions.size(), 9u);
  std::vector<double> alpha1, alpha2;
  for (int k = 0; k < 5; ++k) alpha1.push_back(wrap360(best.program.positions[k].alpha1_deg));
  for (int k = 5; k < 8; ++k) alpha2.push_back(wrap360(best.program.positions[k].alpha2_deg));
  std::sort(alpha1.begin(), alpha1.end());
  for (int k = 0; k < 5; ++k) {
    const double gap = wrap360(alpha1[(k + 1) % 5] - alpha1[k]);
    EXPECT_NEAR(gap, 72.0, 0.05) << "alpha1 spacing " << k;
  }
  const bool paper_set = matches_set(alpha2, {57.47, 122.53, 270.0}, 0.05);
  const bool mirror_set = matches_set(alpha2, {90.0, 237.47, 302.53}, 0.05);
  EXPECT_TRUE(paper_set || mirror_set) << alpha2[0] << " " << alpha2[1] << " " << alpha2[2];
  // The paper's programme is that optimum: same determinant.
  EXPECT_NEAR(best.d_criterion / best.paper9_d_criterion, 1.0, 1e-6);
}

TEST(DesignOptimize, GlobalNinePositionsBeatThePaper) {
  OptimizeOptions options;
  options.positions = 9;
  const OptimizedProgram best = optimize_program(options);
  ASSERT_EQ(best.program.positions.size(), 9u);
  const double gain = best.d_criterion / best.paper9_d_criterion;
  // Issue 3 quotes about 14 %; the criterion is re-evaluated from the programme returned.
  const double recomputed =
      d_criterion(design_basis(poses_of(best.program), DesignModel::invariant));
  EXPECT_NEAR(recomputed, best.d_criterion, 1e-9 * best.d_criterion);
  EXPECT_GT(gain, 1.12);
  EXPECT_LT(gain, 1.17);
}

TEST(DesignEvaluate, ClassicProgramNeedsTheFullModelForGamma) {
  const DesignSettings settings;
  const DesignEvaluation inv = evaluate_design(classic24(), DesignModel::invariant, settings);
  for (int i = kGamma12; i <= kGamma23; ++i) {
    EXPECT_FALSE(inv.unit_sigma[i].has_value());
    EXPECT_NE(inv.unobservable_reason[i].find("regressor is zero"), std::string::npos);
  }
  EXPECT_EQ(inv.d_criterion, 0.0);
  const DesignEvaluation full = evaluate_design(classic24(), DesignModel::full, settings);
  for (int i = 0; i < kUnitParameterCount; ++i) EXPECT_TRUE(full.unit_sigma[i].has_value()) << i;
  EXPECT_GT(full.d_criterion, 0.0);
  EXPECT_EQ(full.time.remounts, 2);
}

TEST(DesignEvaluate, BenchTimeCountsSimultaneousMovesSettleDwellAndRemounts) {
  Program p;
  p.name = "two";
  p.positions.push_back({90, 30, Mount::x, 20.0, std::nullopt});
  p.positions.push_back({60, -30, Mount::y, std::nullopt, 2.0});
  DesignSettings s;
  s.dwell_s = 10;
  const BenchTime t = bench_time(p, s);
  EXPECT_DOUBLE_EQ(t.move_s, 90.0 / 10 + 60.0 / 10);  // the longer axis move sets the time
  EXPECT_DOUBLE_EQ(t.settle_s, 5 + 2);
  EXPECT_DOUBLE_EQ(t.dwell_s, 20 + 10);
  EXPECT_EQ(t.remounts, 1);
  EXPECT_DOUBLE_EQ(t.remount_s, 600);
  EXPECT_DOUBLE_EQ(t.total_s(), 15 + 7 + 30 + 600);
  // A warm-up holds the first position before its dwell: it adds to the time and moves every
  // dwell after it (the wander's covariance between dwells is taken on that timeline).
  Program warmed = p;
  warmed.warmup_s = 3600;
  const BenchTime w = bench_time(warmed, s);
  EXPECT_DOUBLE_EQ(w.warmup_s, 3600);
  EXPECT_DOUBLE_EQ(w.total_s(), t.total_s() + 3600);
  EXPECT_DOUBLE_EQ(dwell_windows(warmed, s)[0].start_s - dwell_windows(p, s)[0].start_s, 3600);
  EXPECT_DOUBLE_EQ(bench_time(repeated_program(warmed, 3), s).warmup_s, 3600);  // once
}

TEST(DesignDwell, PaperProgramDwellForTheIssueTarget) {
  const DesignSettings settings;  // 10 ug/rtHz
  const AccuracyTarget target;    // 2 ug, 2 ppm, 1"
  const DesignBasis basis = design_basis(poses_of(paper9()), DesignModel::invariant);
  const DwellPlan equal = equal_dwell_for_target(basis, target, settings);
  const DwellPlan allocated = allocated_dwell_for_target(basis, target, settings);
  const double limit = continuous_lower_bound_s(DesignModel::invariant, target, settings);
  // Issue 3: about 265 s equal, about 175 s allocated, limit about 105 s.
  EXPECT_NEAR(equal.total_dwell_s, 265, 3);
  EXPECT_EQ(equal.limiting_parameter, "gamma13");  // position 9 alone carries gamma13
  EXPECT_LT(allocated.total_dwell_s, 178);
  EXPECT_GT(allocated.total_dwell_s, limit);
  EXPECT_NEAR(limit, 105, 4);

  // The allocated dwells really meet the target, and only just.
  Program timed = paper9();
  for (std::size_t k = 0; k < timed.positions.size(); ++k)
    timed.positions[k].dwell_s = allocated.dwell_s[k];
  const DesignEvaluation ev = evaluate_design(timed, DesignModel::invariant, settings);
  const auto t = target.sigma_internal();
  double worst = 0;
  for (int i = 0; i < kUnitParameterCount; ++i)
    worst = std::max(worst, *ev.unit_sigma[i] / (t[i] * report_scale(i)));
  EXPECT_NEAR(worst, 1.0, 1e-6);
}

// Monte Carlo: the scatter of the estimates matches evaluate's predicted sigma (600 runs:
// the sample standard deviation is within about 3 % (1 sigma) of the truth, so 10 % holds).
template <class Fit>
void expect_scatter_matches_prediction(const Program& program, DesignModel model, Fit fit,
                                       const char* what) {
  DesignSettings settings;
  settings.dwell_s = 25;
  const DesignEvaluation ev = evaluate_design(program, model, settings);
  const double sigma_g = settings.noise_density_ug_rthz * kUg / std::sqrt(settings.dwell_s);
  const UnitErrors unit = testing::typical_unit();
  StandErrors stand;
  stand.levelling_x_rad = 20 * kArcsecToRad;
  stand.mounting_rad[0] = Vec3(30, -20, 10) * kArcsecToRad;
  const auto poses = poses_of(program);
  const std::vector<PositionAverage> clean =
      testing::synthetic_averages(poses, unit, stand, sigma_g);
  constexpr int kRuns = 600;
  constexpr double kTolerance = 0.1;
  std::mt19937_64 rng(77);
  std::normal_distribution<double> gauss(0, 1);
  std::array<std::vector<double>, kUnitParameterCount> estimates;
  for (int run = 0; run < kRuns; ++run) {
    std::vector<PositionAverage> noisy = clean;
    for (auto& pa : noisy)
      for (int a = 0; a < 3; ++a) pa.mean_g[a] += sigma_g * gauss(rng);
    const FitResult r = fit(noisy);
    for (int i = 0; i < kUnitParameterCount; ++i)
      estimates[i].push_back(*r.unit[i].value * report_scale(i));
  }
  for (int i = 0; i < kUnitParameterCount; ++i) {
    double mean = 0, var = 0;
    for (double e : estimates[i]) mean += e / kRuns;
    for (double e : estimates[i]) var += (e - mean) * (e - mean) / (kRuns - 1);
    ASSERT_TRUE(ev.unit_sigma[i].has_value());
    EXPECT_NEAR(std::sqrt(var) / *ev.unit_sigma[i], 1.0, kTolerance)
        << what << " " << kUnitParameterNames[i] << ": scatter " << std::sqrt(var) << " predicted "
        << *ev.unit_sigma[i];
  }
}

// evaluate's prediction is for white noise: the estimators weight as white here (with the
// default, estimated noise model they agree too, at the price of a REML fit per run).
TEST(DesignEvaluate, PredictedSigmaMatchesInvariantEstimatorScatter) {
  STANDCAL_STATISTICAL_TEST();
  expect_scatter_matches_prediction(
      paper9(), DesignModel::invariant,
      [](const std::vector<PositionAverage>& a) {
        return fit_invariant_joint(a, white_noise_weighting());
      },
      "invariant");
}

TEST(DesignEvaluate, PredictedSigmaMatchesFullEstimatorScatter) {
  STANDCAL_STATISTICAL_TEST();
  expect_scatter_matches_prediction(
      paper9(), DesignModel::full,
      [](const std::vector<PositionAverage>& a) {
        return fit_full_vector(a, white_noise_weighting());
      },
      "full");
}

TEST(DesignTarget, ParsesTheIssueSyntaxAndRejectsNonsense) {
  const AccuracyTarget t = parse_accuracy_target("bias=2ug,scale=3ppm,gamma=1asec");
  EXPECT_EQ(t.bias_ug, 2);
  EXPECT_EQ(t.scale_ppm, 3);
  EXPECT_EQ(t.gamma_arcsec, 1);
  EXPECT_THROW(parse_accuracy_target("bias=2ppm"), std::invalid_argument);
  EXPECT_THROW(parse_accuracy_target("speed=2"), std::invalid_argument);
  EXPECT_THROW(parse_accuracy_target("bias=-1ug"), std::invalid_argument);
}

}  // namespace
}  // namespace standcal
