// Experiment design under bias wander (issue 21): the dwell means' covariance for a
// programme's schedule, the predicted sigmas against the scatter of the fit that knows the
// wander, and the dwell plans that revisiting beats.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <optional>
#include <random>
#include <vector>

#include "calib/design.hpp"
#include "calib/full_estimator.hpp"
#include "calib/invariant_estimator.hpp"
#include "tests/design/synthetic.hpp"
#include "tests/support/statistical.hpp"

namespace standcal {
namespace {

// The covariance of two window means by the midpoint rule: (1 / (Ta Tb)) double integral of
// exp(-|t - s| / tau).
double brute_force_covariance(const DwellWindow& a, const DwellWindow& b, double tau_s) {
  constexpr int kSteps = 1500;
  const double ha = a.length_s / kSteps, hb = b.length_s / kSteps;
  double sum = 0;
  for (int i = 0; i < kSteps; ++i) {
    const double s = a.start_s + (i + 0.5) * ha;
    for (int j = 0; j < kSteps; ++j)
      sum += std::exp(-std::abs(b.start_s + (j + 0.5) * hb - s) / tau_s);
  }
  return sum / (static_cast<double>(kSteps) * kSteps);
}

TEST(WanderCovariance, IsTheAverageOfTheProcessOverBothWindows) {
  const double tau_s = 300;
  for (const double length_s : {30.0, 600.0, 9000.0}) {
    const DwellWindow w{100, length_s};
    // The diagonal's kink costs the midpoint rule O(h): 1e-3 holds for these windows.
    EXPECT_NEAR(wander_mean_covariance(w, w, tau_s), brute_force_covariance(w, w, tau_s), 1e-3)
        << "one window of " << length_s << " s";
  }
  const DwellWindow first{0, 25}, second{180, 60};
  EXPECT_NEAR(wander_mean_covariance(first, second, tau_s),
              brute_force_covariance(first, second, tau_s), 1e-6);
  EXPECT_DOUBLE_EQ(wander_mean_covariance(first, second, tau_s),
                   wander_mean_covariance(second, first, tau_s));
  // A short window is the process at one time: variance 1, correlation exp(-gap / tau).
  EXPECT_NEAR(wander_mean_covariance({0, 1e-3}, {0, 1e-3}, tau_s), 1, 1e-5);
  EXPECT_NEAR(wander_mean_covariance({0, 1e-3}, {300, 1e-3}, tau_s), std::exp(-1), 1e-5);
}

TEST(ScheduledInformation, AVanishingWanderGivesTheWhiteInformation) {
  for (const DesignModel model : {DesignModel::invariant, DesignModel::full}) {
    const Program program = paper9();
    const DesignBasis basis = design_basis(poses_of(program), model);
    DesignSettings white;
    const std::vector<double> dwell_s{10, 20, 30, 10, 20, 30, 10, 20, 30};
    const Eigen::MatrixXd m_white = scheduled_information(basis, program, white, dwell_s);
    DesignSettings faint = white;
    faint.bias_instability_ug = 1e-6;  // 1e-7 of a dwell mean's white error
    const Eigen::MatrixXd m_faint = scheduled_information(basis, program, faint, dwell_s);
    EXPECT_LT((m_faint - m_white).norm(), 1e-6 * m_white.norm()) << design_model_name(model);
    // The white information is sum_k T_k / N^2 G_k^T G_k.
    const double n_g = white.noise_density_ug_rthz * kUg;
    Eigen::MatrixXd expected = Eigen::MatrixXd::Zero(basis.columns(), basis.columns());
    for (std::size_t k = 0; k < basis.blocks.size(); ++k)
      expected += dwell_s[k] / (n_g * n_g) * basis.blocks[k].transpose() * basis.blocks[k];
    EXPECT_LT((m_white - expected).norm(), 1e-12 * expected.norm());
  }
}

// A Gauss-Markov wander per axis, simulated on a 0.5 s grid through the programme's
// schedule and averaged over each dwell: independent of the closed form under test.
std::vector<Vec3> simulated_wander_means(const std::vector<DwellWindow>& windows, double q_g,
                                         double tau_s, std::mt19937_64& rng) {
  constexpr double kStepS = 0.5;
  std::normal_distribution<double> gauss(0, 1);
  const double phi = std::exp(-kStepS / tau_s);
  const double drive = q_g * std::sqrt(1 - phi * phi);
  Vec3 b(q_g * gauss(rng), q_g * gauss(rng), q_g * gauss(rng));
  double t = 0;
  std::vector<Vec3> means;
  for (const DwellWindow& w : windows) {
    for (; t < w.start_s; t += kStepS)
      for (int a = 0; a < 3; ++a) b[a] = phi * b[a] + drive * gauss(rng);
    Vec3 sum = Vec3::Zero();
    int n = 0;
    for (; t < w.start_s + w.length_s; t += kStepS, ++n) {
      for (int a = 0; a < 3; ++a) b[a] = phi * b[a] + drive * gauss(rng);
      sum += b;
    }
    means.push_back(sum / n);
  }
  return means;
}

// Monte Carlo: paper9 with 25 s dwells, white error 2 ug per dwell mean and wander of 3x
// that (tau 300 s). The fits are given the true wander (FitNoiseOptions::specified), so
// the scatter of their estimates is what the design predicts. 600 runs: a sample standard
// deviation is within about 3 % (1 sigma) of the truth; 10 % holds. Each fit's own sigma
// is the prediction: both take the wander's mean over each dwell. This failed before, when
// the fits took the wander's value at each dwell's mid-time, which overstates how much of it
// the difference of two neighbouring dwells sees (for 25 s dwells 10 s apart, 0.22 q^2
// against the exact 0.16 q^2): their sigmas were 1.00-1.06 of the prediction.
template <class Fit>
void expect_wander_scatter_matches_prediction(DesignModel model, Fit fit, const char* what) {
  const Program program = paper9();
  DesignSettings settings;
  settings.dwell_s = 25;
  const double sigma_g = settings.noise_density_ug_rthz * kUg / std::sqrt(settings.dwell_s);
  settings.bias_instability_ug = 3 * sigma_g / kUg;
  const DesignEvaluation ev = evaluate_design(program, model, settings);
  const std::vector<DwellWindow> windows = dwell_windows(program, settings);
  std::vector<PositionAverage> clean =
      testing::synthetic_averages(poses_of(program), testing::typical_unit(), {}, sigma_g);
  for (std::size_t k = 0; k < clean.size(); ++k) {
    clean[k].t_start_s = windows[k].start_s;
    clean[k].t_end_s = windows[k].start_s + windows[k].length_s;
  }
  FitNoiseOptions noise;
  noise.mode = FitNoiseOptions::Mode::specified;
  noise.specified = {Vec3::Constant(settings.bias_instability_ug * kUg),
                     settings.bias_instability_tau_s};
  constexpr int kRuns = 600;
  std::mt19937_64 rng(2112);
  std::normal_distribution<double> gauss(0, 1);
  std::array<std::vector<double>, kUnitParameterCount> estimates;
  std::array<double, kUnitParameterCount> fit_sigma{};
  for (int run = 0; run < kRuns; ++run) {
    std::vector<PositionAverage> noisy = clean;
    const std::vector<Vec3> wander = simulated_wander_means(
        windows, settings.bias_instability_ug * kUg, settings.bias_instability_tau_s, rng);
    for (std::size_t k = 0; k < noisy.size(); ++k)
      for (int a = 0; a < 3; ++a) noisy[k].mean_g[a] += wander[k][a] + sigma_g * gauss(rng);
    const FitResult r = fit(noisy, noise);
    for (int i = 0; i < kUnitParameterCount; ++i) {
      estimates[i].push_back(*r.unit[i].value * report_scale(i));
      fit_sigma[i] = *r.unit[i].sigma * report_scale(i);
    }
  }
  for (int i = 0; i < kUnitParameterCount; ++i) {
    double mean = 0, var = 0;
    for (double e : estimates[i]) mean += e / kRuns;
    for (double e : estimates[i]) var += (e - mean) * (e - mean) / (kRuns - 1);
    ASSERT_TRUE(ev.unit_sigma[i].has_value());
    EXPECT_NEAR(std::sqrt(var) / *ev.unit_sigma[i], 1.0, 0.1)
        << what << " " << kUnitParameterNames[i] << ": scatter " << std::sqrt(var) << " predicted "
        << *ev.unit_sigma[i];
    EXPECT_NEAR(fit_sigma[i] / *ev.unit_sigma[i], 1.0, 0.01)
        << what << " " << kUnitParameterNames[i] << ": the fit's sigma " << fit_sigma[i];
    // The wander matters here: the white-noise prediction would be too small.
    ASSERT_TRUE(ev.white_unit_sigma[i].has_value());
    EXPECT_LT(*ev.white_unit_sigma[i], *ev.unit_sigma[i]) << what << " " << kUnitParameterNames[i];
  }
}

TEST(DesignEvaluate, UnderWanderPredictedSigmaMatchesTheFullEstimatorsScatter) {
  STANDCAL_STATISTICAL_TEST();
  expect_wander_scatter_matches_prediction(
      DesignModel::full,
      [](const std::vector<PositionAverage>& a, const FitNoiseOptions& n) {
        return fit_full_vector(a, n);
      },
      "full");
}

TEST(DesignEvaluate, UnderWanderPredictedSigmaMatchesTheInvariantEstimatorsScatter) {
  STANDCAL_STATISTICAL_TEST();
  expect_wander_scatter_matches_prediction(
      DesignModel::invariant,
      [](const std::vector<PositionAverage>& a, const FitNoiseOptions& n) {
        return fit_invariant_joint(a, n);
      },
      "invariant");
}

// The largest sigma / target over the unit parameters of a programme run with `dwell_s`.
double worst_sigma_over_target(const Program& program, const std::vector<double>& dwell_s,
                               const AccuracyTarget& target, const DesignSettings& settings) {
  Program timed = program;
  for (std::size_t k = 0; k < timed.positions.size(); ++k) timed.positions[k].dwell_s = dwell_s[k];
  const DesignEvaluation ev = evaluate_design(timed, DesignModel::invariant, settings);
  const auto t = target.sigma_internal();
  double worst = 0;
  for (int i = 0; i < kUnitParameterCount; ++i)
    worst = std::max(worst, *ev.unit_sigma[i] / (t[i] * report_scale(i)));
  return worst;
}

// The correlation time known as a range (`standcal noise`'s), as the fits take it: each
// parameter's predicted variance is its average over the range's five times, or the
// log-middle's (which the fit weights with) where that is larger.
TEST(DesignEvaluate, ACorrelationTimeGivenAsARangeAveragesTheVarianceOverIt) {
  const Program program = paper9();
  DesignSettings settings;
  settings.bias_instability_ug = 3;
  settings.dwell_s = 60;
  settings.bias_instability_tau_s = 150;
  settings.bias_instability_tau_max_s = 600;
  const DesignEvaluation over_range = evaluate_design(program, DesignModel::invariant, settings);
  const std::vector<double> taus = settings.wander_tau().grid_s();
  ASSERT_EQ(taus.size(), 5u);
  const auto variances_at = [&](double tau_s) {
    DesignSettings one = settings;
    one.bias_instability_tau_s = tau_s;
    one.bias_instability_tau_max_s = 0;
    const DesignEvaluation at = evaluate_design(program, DesignModel::invariant, one);
    std::array<double, kUnitParameterCount> v{};
    for (int j = 0; j < kUnitParameterCount; ++j) v[j] = *at.unit_sigma[j] * *at.unit_sigma[j];
    return v;
  };
  std::array<double, kUnitParameterCount> mean_variance{};
  for (const double tau_s : taus)
    for (int j = 0; j < kUnitParameterCount; ++j)
      mean_variance[j] += variances_at(tau_s)[j] / static_cast<double>(taus.size());
  const auto at_middle = variances_at(300);
  int floored = 0;
  for (int j = 0; j < kUnitParameterCount; ++j) {
    const double expected = std::max(mean_variance[j], at_middle[j]);
    floored += at_middle[j] > mean_variance[j] ? 1 : 0;
    EXPECT_NEAR(*over_range.unit_sigma[j], std::sqrt(expected), 1e-6 * std::sqrt(expected))
        << kUnitParameterNames[j];
  }
  // Both cases occur here: the biases' average lies below the middle's, others' above.
  EXPECT_GT(floored, 0);
  EXPECT_LT(floored, kUnitParameterCount);
}

// A wander of 1e-9 ug takes the searched path; its plans are the white ones (which scale
// one closed-form load) to the search's resolution.
TEST(DesignDwell, AVanishingWandersSearchedPlansAreTheWhiteOnes) {
  const Program program = paper9();
  const DesignBasis basis = design_basis(poses_of(program), DesignModel::invariant);
  const AccuracyTarget target;
  const DesignSettings white;
  DesignSettings faint = white;
  faint.bias_instability_ug = 1e-9;
  const DwellPlan equal_white = equal_dwell_for_target(basis, target, white);
  const DwellPlan equal_faint = equal_dwell_for_target(basis, program, target, faint);
  ASSERT_TRUE(equal_faint.feasible) << equal_faint.reason;
  EXPECT_NEAR(equal_faint.dwell_s.front() / equal_white.dwell_s.front(), 1, 2e-4);
  EXPECT_EQ(equal_faint.limiting_parameter, equal_white.limiting_parameter);
  const DwellPlan allocated_white = allocated_dwell_for_target(basis, target, white);
  const DwellPlan allocated_faint = allocated_dwell_for_target(basis, program, target, faint);
  ASSERT_TRUE(allocated_faint.feasible) << allocated_faint.reason;
  EXPECT_NEAR(allocated_faint.total_dwell_s / allocated_white.total_dwell_s, 1, 2e-4);
}

// Issue 21: "revisiting positions and shorter dwells can beat long ones when the noise is
// not white". paper9 for the issue-3 target with a 3 ug wander of 300 s.
TEST(DesignDwell, UnderWanderRevisitingBeatsDwellingLonger) {
  const Program once = paper9();
  const Program four_times = repeated_program(once, 4);
  ASSERT_EQ(four_times.positions.size(), 36u);
  EXPECT_EQ(four_times.name, "paper9 x4");
  const AccuracyTarget target;
  DesignSettings settings;
  settings.bias_instability_ug = 3;
  const auto plan = [&](const Program& p) {
    return equal_dwell_for_target(design_basis(poses_of(p), DesignModel::invariant), p, target,
                                  settings);
  };
  const DwellPlan long_dwells = plan(once), revisits = plan(four_times);
  ASSERT_TRUE(long_dwells.feasible) << long_dwells.reason;
  ASSERT_TRUE(revisits.feasible) << revisits.reason;
  const double bench_once = bench_time(once, settings, long_dwells.dwell_s).total_s();
  const double bench_revisits = bench_time(four_times, settings, revisits.dwell_s).total_s();
  EXPECT_LT(2 * bench_revisits, bench_once)
      << "one pass " << bench_once << " s, four passes " << bench_revisits << " s";
  EXPECT_LT(revisits.dwell_s.front(), long_dwells.dwell_s.front());

  // Each plan meets the target, and only just: the search found the least dwell.
  EXPECT_NEAR(worst_sigma_over_target(once, long_dwells.dwell_s, target, settings), 1.0, 1e-3);
  EXPECT_NEAR(worst_sigma_over_target(four_times, revisits.dwell_s, target, settings), 1.0, 1e-3);
}

TEST(DesignDwell, AllocatedDwellUnderWanderMeetsTheTarget) {
  const Program program = paper9();
  const DesignBasis basis = design_basis(poses_of(program), DesignModel::invariant);
  const AccuracyTarget target = parse_accuracy_target("bias=5ug,scale=5ppm,gamma=3asec");
  DesignSettings settings;
  settings.bias_instability_ug = 3;
  const DwellPlan plan = allocated_dwell_for_target(basis, program, target, settings);
  ASSERT_TRUE(plan.feasible) << plan.reason;
  EXPECT_NEAR(worst_sigma_over_target(program, plan.dwell_s, target, settings), 1.0, 1e-3);
}

// A wander slow against any run is an offset the biases cannot be told from: no dwell
// brings them under it, and the plan says so with the floor.
TEST(DesignDwell, AWanderSlowerThanAnyRunSetsAFloorThePlanNames) {
  const Program program = paper9();
  DesignSettings settings;
  settings.bias_instability_ug = 10;
  settings.bias_instability_tau_s = 1e8;
  const DwellPlan plan = equal_dwell_for_target(design_basis(poses_of(program), DesignModel::full),
                                                program, AccuracyTarget{}, settings);
  EXPECT_FALSE(plan.feasible);
  EXPECT_NE(plan.reason.find("bias_"), std::string::npos) << plan.reason;
  EXPECT_NE(plan.reason.find("for any dwell up to 86400 s per position"), std::string::npos)
      << plan.reason;
}

// Issue 21: "shows how the best programme ... change[s]" under wander. White noise's
// D-optimal angles do not see when each position is visited; moved for a 10 ug wander of
// 300 s (the issue-3 target, visited up to four times), the nine positions reach the target
// in about two thirds of the bench time (measured: 80924 s -> 52770 s), and the moved
// programme's plan meets the target, only just.
TEST(DesignOptimize, UnderWanderAnglesMovedForItReachTheTargetSooner) {
  OptimizeOptions options;
  options.limits.alpha1.continuous = options.limits.alpha2.continuous = true;
  const Program white_optimum = optimize_program(options).program;
  const AccuracyTarget target;
  DesignSettings settings;
  settings.bias_instability_ug = 10;
  const WanderPolish polish =
      polish_for_wander(white_optimum, DesignModel::invariant, options.limits, target, settings, 4);
  ASSERT_TRUE(polish.start_plan && polish.plan);
  EXPECT_GE(polish.rounds, 1);
  EXPECT_LT(polish.plan->time.total_s(), 0.8 * polish.start_plan->time.total_s())
      << "moved: " << polish.plan->time.total_s()
      << " s, white noise's angles: " << polish.start_plan->time.total_s() << " s";
  // The plan reported is the moved programme's own, and it meets the target, only just.
  const std::optional<RevisitPlan> replanned =
      fastest_revisit(polish.program, DesignModel::invariant, target, settings, 4);
  ASSERT_TRUE(replanned);
  EXPECT_EQ(replanned->times, polish.plan->times);
  EXPECT_DOUBLE_EQ(replanned->time.total_s(), polish.plan->time.total_s());
  const Program visited = repeated_program(polish.program, polish.plan->times);
  EXPECT_NEAR(worst_sigma_over_target(visited, polish.plan->equal.dwell_s, target, settings), 1.0,
              1e-3);
  EXPECT_EQ(polish.program.name, white_optimum.name + "-wander");
}

// On a stand whose alpha2 turns only from -30 to 30 degrees the moved angles stay inside it
// (some press against its ends), and a programme is never handed back slower than it came;
// without wander it is not moved.
TEST(DesignOptimize, AnglesMovedForTheWanderStayOnTheStandAndNeverSlowThePlan) {
  OptimizeOptions options;
  options.limits.alpha1 = AxisRange::continuous_axis();
  options.limits.alpha2 = {false, -30.0, 30.0, CableWrap::nearest};
  const Program white_optimum = optimize_program(options).program;
  DesignSettings settings;
  settings.bias_instability_ug = 3;
  const WanderPolish polish = polish_for_wander(white_optimum, DesignModel::invariant,
                                                options.limits, AccuracyTarget{}, settings, 4);
  ASSERT_TRUE(polish.start_plan && polish.plan);
  EXPECT_GE(polish.rounds, 1) << "nothing moved: the limits below are not put to the test";
  EXPECT_LE(polish.plan->time.total_s(), polish.start_plan->time.total_s());
  int at_an_end = 0;
  for (const ProgramPosition& p : polish.program.positions) {
    EXPECT_GE(p.alpha2_deg, -30.0);
    EXPECT_LE(p.alpha2_deg, 30.0);
    at_an_end += std::abs(std::abs(p.alpha2_deg) - 30.0) < 1e-9 ? 1 : 0;
  }
  EXPECT_GT(at_an_end, 0) << "no position meets the stand's limit: the clamp is not tested";
  const WanderPolish white = polish_for_wander(
      white_optimum, DesignModel::invariant, options.limits, AccuracyTarget{}, DesignSettings{}, 4);
  EXPECT_EQ(white.rounds, 0);
  for (std::size_t k = 0; k < white_optimum.positions.size(); ++k) {
    EXPECT_EQ(white.program.positions[k].alpha1_deg, white_optimum.positions[k].alpha1_deg);
    EXPECT_EQ(white.program.positions[k].alpha2_deg, white_optimum.positions[k].alpha2_deg);
  }
}

}  // namespace
}  // namespace standcal
