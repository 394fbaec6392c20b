// Issue 21: dwell means close in time share bias wander, and the fits weight for it.
// The algebra of the noise model, then a seeded subset of bench/noise's Monte Carlo: the
// z-variance of the fitted parameters about the truth with white noise and with wander.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <random>
#include <regex>

#include "bench/noise/noise_mc.hpp"
#include "calib/allan.hpp"
#include "calib/averaging.hpp"
#include "calib/diagnosis/diagnosis.hpp"
#include "calib/diagnosis/wander.hpp"
#include "calib/full_estimator.hpp"
#include "calib/invariant_estimator.hpp"
#include "calib/norm_calibration.hpp"
#include "calib/raw_input.hpp"
#include "calib/recording_digest.hpp"
#include "calib/report.hpp"
#include "calib/simulator.hpp"
#include "calib/static_noise.hpp"
#include "calib/text.hpp"
#include "calib/units.hpp"
#include "tests/calib/test_support.hpp"
#include "tests/support/statistical.hpp"
#include "tests/support/temp_dir.hpp"

using namespace standcal;

namespace {

// Mean z^2 over n runs of an honest sigma: 1 with sd sqrt(2 / n) (0.18 for 60 runs, 0.22
// for 40): [0.3, 1.9] is beyond 3.5 sd on either side.
constexpr int kRunsWander = 60;
constexpr int kRunsWhite = 40;
// A wander the run's rows cannot pin: its z-variance has heavier tails, so more runs.
constexpr int kRunsUnpinnedWander = 200;
constexpr int kRunsWarmedUpWhite = 100;
constexpr double kHonestZ2Min = 0.3, kHonestZ2Max = 1.9;
// Measured over 1000 runs: 90-93 % (docs/calibration.md); over 60 runs a share of 0.9 has
// sd 0.04, so 0.75 is 3.5 sd below.
constexpr double kMinCoverageWander = 0.75;

void expect_honest(const noise_mc::ZStats& z) {
  for (std::size_t j = 0; j < z.n.size(); ++j) {
    if (z.n[j] == 0) continue;
    EXPECT_GT(z.z2_mean[j], kHonestZ2Min) << z.estimator << " " << kUnitParameterNames[j];
    EXPECT_LT(z.z2_mean[j], kHonestZ2Max) << z.estimator << " " << kUnitParameterNames[j];
  }
}

std::vector<NoiseRow> random_rows(int n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<NoiseRow> rows;
  double t = 0;
  for (int r = 0; r < n; ++r) {
    if (r % 3 == 0) t += 5 + 60 * u(rng);  // three rows per dwell share its time
    rows.push_back(
        {t, Vec3(u(rng) - 0.5, u(rng) - 0.5, u(rng) - 0.5).normalized(), (1 + 2 * u(rng)) * kUg});
  }
  return rows;
}

noise_mc::ScenarioResult monte_carlo(const noise_mc::Scenario& s, int runs,
                                     double tau_given_range = 1, double output_filter_tau_s = 0) {
  noise_mc::Setup setup;
  setup.program = diagnostic32();
  setup.runs = runs;
  setup.tau_given_range = tau_given_range;
  setup.output_filter_tau_s = output_filter_tau_s;
  setup.first_seed = 7000;
  return noise_mc::run_scenario(setup, s);
}

// The norm fit of `raw` (the recording without its angles), nothing of the unit's given,
// without its threshold-stability refits.
NormCalibration norm_fit_of(const RawInput& raw) {
  NormCalibrationOptions options;
  options.stability = false;
  return calibrate_without_angles(raw, options);
}

const noise_mc::ZStats& stats(const noise_mc::ScenarioResult& r, const std::string& estimator,
                              const std::string& weighting) {
  for (const auto& z : r.stats)
    if (z.estimator == estimator && z.weighting == weighting) return z;
  throw std::runtime_error("no such statistics");
}

// The smallest share, over the parameters, of runs whose +-1.96 sigma holds the truth.
double min_coverage(const noise_mc::ZStats& z) {
  double c = 1;
  for (std::size_t j = 0; j < z.n.size(); ++j)
    if (z.n[j] > 0) c = std::min(c, z.coverage95[j]);
  return c;
}

// One seeded diagnostic32 run with wander `times` the white error of a dwell mean (of the
// default unit's correlation time unless `tau_s` is given).
Recording wander_run(double times, std::uint64_t seed, double tau_s = 0) {
  SimulationRequest req;
  req.program = diagnostic32();
  req.truth = default_truth();
  req.truth.noise.bias_instability_ug = times * req.truth.noise.density_ug_rthz / std::sqrt(10.0);
  if (tau_s > 0) req.truth.noise.bias_instability_tau_s = tau_s;
  req.timing.dwell_s = 10;
  req.timing.sample_rate_hz = 25;
  req.seed = seed;
  return simulate_run(req);
}

Recording wander_ten_times_run() { return wander_run(10, 11); }

}  // namespace

TEST(NoiseModelAlgebra, DecorrelateIsTheInverseSquareRootOfTheRowCovariance) {
  const std::vector<NoiseRow> rows = random_rows(30, 3);
  const GaussMarkovNoise noise{Vec3(2, 3, 1) * kUg, 200};
  Eigen::VectorXd w(30);
  for (int r = 0; r < 30; ++r) w[r] = 1 / rows[static_cast<std::size_t>(r)].sigma_g;
  const Eigen::MatrixXd Cw = w.asDiagonal() * row_covariance(rows, noise) * w.asDiagonal();
  double log_det = 0;
  const Eigen::MatrixXd K = decorrelate(rows, noise, Eigen::MatrixXd::Identity(30, 30), &log_det);
  EXPECT_LT((K * Cw * K.transpose() - Eigen::MatrixXd::Identity(30, 30)).norm(), 1e-9);
  const Eigen::LLT<Eigen::MatrixXd> llt(Cw);
  EXPECT_NEAR(log_det, 2 * llt.matrixL().toDenseMatrix().diagonal().array().log().sum(), 1e-9);
}

TEST(NoiseModelAlgebra, WhiteNoiseHasADiagonalCovariance) {
  const std::vector<NoiseRow> rows = random_rows(9, 4);
  const Eigen::MatrixXd C = row_covariance(rows, GaussMarkovNoise{});
  for (int r = 0; r < 9; ++r)
    EXPECT_DOUBLE_EQ(C(r, r), rows[static_cast<std::size_t>(r)].sigma_g *
                                  rows[static_cast<std::size_t>(r)].sigma_g);
  EXPECT_DOUBLE_EQ(C.norm(), C.diagonal().norm());
}

TEST(FitNoise, TheFitJsonStatesTheNoiseModelItWeightedWith) {
  const FitResult fit = fit_full_vector(average_positions(wander_ten_times_run()));
  const nlohmann::json j = fit_to_json(fit)["noise"];
  ASSERT_EQ(j["model"], "gauss_markov") << j.dump(2);
  EXPECT_EQ(j["source"], "estimated");
  EXPECT_GT(j["lr"].get<double>(), j["lr_threshold"].get<double>());
  EXPECT_GT(j["sigma_sqrt_n_understated_by"][0].get<double>(), 2.0);
}

// Wander 10x the white error of a dwell mean: weighted as white, the biases' intervals
// hardly ever hold the truth; weighted by the run's own noise model they mostly do. One
// 32-position run pins the wander's correlation time poorly, so coverage stays short of
// 95 % (bench/noise, 1000 runs: docs/calibration.md) — the bound says so rather than hides it.
TEST(FitNoise, WanderTenTimesTheDwellErrorIsWeightedForAndTheIntervalsHoldTheTruth) {
  const auto r = monte_carlo({"wander 10x", 10, 300}, kRunsWander);
  EXPECT_LT(min_coverage(stats(r, "full", "white")), 0.3)
      << "the scenario does not stress the weighting";
  for (const char* estimator : {"full", "joint", "norm"}) {
    const noise_mc::ZStats& z = stats(r, estimator, "estimated");
    EXPECT_GE(z.wander_significant, z.runs * 9 / 10) << estimator;
    EXPECT_GE(min_coverage(z), kMinCoverageWander) << estimator;
  }
}

// Wander 3x the white error of a dwell mean: the invariant fit, one row per position,
// pinned it poorly from its own rows (biases at 2.5-3.4 in variance over 1000 runs); it now
// weights with the wander the full vector of the same dwell means shows. Over 60 runs
// honest is [0.3, 1.9]; this failed before (joint biases 2.07, 2.28 and 5.57 in variance).
TEST(FitNoise, WanderThreeTimesTheDwellErrorTheJointFitIsHonestWithTheFullVectorsWander) {
  const auto r = monte_carlo({"wander 3x", 3, 300}, kRunsWander);
  const noise_mc::ZStats& z = stats(r, "joint", "estimated");
  EXPECT_GE(z.wander_significant, z.runs * 9 / 10);
  expect_honest(z);
}

// Wander 3x the white error of a dwell mean, the norm fit: from its own 32 rows, an axis
// whose own q came out low by chance had its bias sigma too small (biases at 2.5-3.5 in
// variance over 1000 runs); an axis now leaves the common q only where its rows demand it
// (0.76-0.99). Over 60 runs honest is [0.3, 1.9]; this failed before (norm biases 2.13,
// 2.27 and 6.01 in variance; 0.39, 0.48 and 0.77 with the rule).
TEST(FitNoise, WanderThreeTimesTheDwellErrorTheNormFitIsHonestWithACommonWander) {
  const auto r = monte_carlo({"wander 3x", 3, 300}, kRunsWander);
  const noise_mc::ZStats& z = stats(r, "norm", "estimated");
  EXPECT_GE(z.wander_significant, z.runs * 3 / 4);
  expect_honest(z);
}

// An axis whose rows pin its wander poorly (the norm fit's 32 rows) went to no wander at all
// by chance under a 10x wander, at the one-parameter bar of P = 0.01 (NoiseEstimateOptions::
// axis_lr), in 3 of 400 runs of the Monte Carlo: these three seeds, whose bias on that axis
// was then 12.2, 11.9 and 5.6 sigma off the truth (z^2 148, 142 and 31), and the biases'
// z-variance 1.88 over the 400 runs. An axis's q below the common one now needs P = 1e-3
// (axis_quieter_lr): the same biases are 0.92, 1.33 and 0.23 (z^2), and none of 400 runs
// leaves an axis without wander.
TEST(FitNoise, AnAxisIsNotLeftWithoutWanderByChance) {
  for (const std::uint64_t seed : {70, 239, 376}) {
    noise_mc::Setup setup;
    setup.program = diagnostic32();
    setup.runs = 1;
    setup.threads = 1;
    setup.first_seed = seed;
    const auto r = noise_mc::run_scenario(setup, {"wander 10x", 10, 300});
    const noise_mc::ZStats& z = stats(r, "norm", "tau given");
    ASSERT_EQ(z.failed, 0);
    for (int bias = 0; bias < 3; ++bias)
      EXPECT_LT(z.z2_mean[static_cast<std::size_t>(bias)], 9)
          << "seed " << seed << " " << kUnitParameterNames[static_cast<std::size_t>(bias)];
  }
}

// One run cannot tell a wander of 60 s from one of 1200 s, and the biases' variance differs
// 40-60-fold between them: estimated from the run, a 60 s wander's biases get sigmas far too
// wide (z-variance 0.37-0.47 over 1000 runs, full and joint at 3x). Given the unit's
// correlation time, the run estimates only the wander's size and the sigmas hold
// (1.05-1.12). Over 60 runs honest is [0.3, 1.9].
TEST(FitNoise, AGivenCorrelationTimeMakesTheBiasesSigmasHonestWhereTheRunCannotPinIt) {
  const auto r = monte_carlo({"wander 3x", 3, 60}, kRunsWander);
  for (const char* estimator : {"full", "joint"}) {
    const noise_mc::ZStats& estimated = stats(r, estimator, "estimated");
    const noise_mc::ZStats& given = stats(r, estimator, "tau given");
    expect_honest(given);
    for (int bias = 0; bias < 3; ++bias) {
      EXPECT_LT(estimated.z2_mean[static_cast<std::size_t>(bias)], 0.7)
          << estimator << " " << kUnitParameterNames[static_cast<std::size_t>(bias)]
          << ": the scenario does not show what the given time is for";
      EXPECT_GT(given.z2_mean[static_cast<std::size_t>(bias)],
                1.5 * estimated.z2_mean[static_cast<std::size_t>(bias)])
          << estimator << " " << kUnitParameterNames[static_cast<std::size_t>(bias)];
    }
  }
}

// A dwell mean averages the wander over its dwell, and consecutive means differ less than the
// wander's values at their mid-times would (13 % in variance for 10 s dwells 30 s apart at
// tau = 300 s). Taken as values at mid-times, the wander's size fitted with tau given came out
// too small: q^2 at 0.878 of the truth on average under a 10x wander (1000 runs), and the
// biases' z-variance 1.07-1.14 (full, joint); 0.95-1.00 with the dwell as a window. Over 100
// runs the mean of q^2 / truth has sd about 0.02; this failed before (0.87).
TEST(FitNoise, TheWandersSizeFittedWithTauGivenIsNotTooSmall) {
  STANDCAL_STATISTICAL_TEST();
  FitNoiseOptions given;
  given.known_tau = KnownTau{300, 300};
  const double truth_ug = 10 * default_truth().noise.density_ug_rthz / std::sqrt(10.0);
  double sum = 0;
  int runs = 0;
  for (std::uint64_t seed = 1; seed <= 100; ++seed) {
    const FitResult fit = fit_full_vector(average_positions(wander_run(10, seed)), given);
    for (int a = 0; a < 3; ++a) sum += std::pow(fit.noise.wander_ug[a] / truth_ug, 2);
    ++runs;
  }
  const double mean = sum / (3 * runs);
  EXPECT_GT(mean, 0.94) << "the fitted q^2 over the truth's, averaged";
  EXPECT_LT(mean, 1.08) << "the fitted q^2 over the truth's, averaged";
}

// The correlation time known only as a range, a factor 2 either way of the truth (a
// two-hour static recording's Allan fit allows about that at 60 s: `standcal noise`): the
// fit weighs five times of the range by the run's likelihood and averages the biases'
// variance over them. Over 1000 runs at 3x, full and joint: see docs/calibration.md; the
// estimated tau's 0.34-0.57 is far too wide.
TEST(FitNoise, ACorrelationTimeGivenAsARangeKeepsTheBiasesSigmasHonest) {
  const auto r = monte_carlo({"wander 3x", 3, 60}, kRunsWander, 2);
  for (const char* estimator : {"full", "joint"}) {
    const noise_mc::ZStats& estimated = stats(r, estimator, "estimated");
    const noise_mc::ZStats& range = stats(r, estimator, "tau given");
    expect_honest(range);
    for (int bias = 0; bias < 3; ++bias)
      EXPECT_GT(range.z2_mean[static_cast<std::size_t>(bias)],
                1.3 * estimated.z2_mean[static_cast<std::size_t>(bias)])
          << estimator << " " << kUnitParameterNames[static_cast<std::size_t>(bias)];
  }
}

// Where the wander comes from, in the fit's own words; the norm fit, whose attitudes are
// read off the means themselves, estimates it from its own rows.
TEST(FitNoise, TheJointFitSaysItTookTheWanderFromTheFullVector) {
  const Recording rec = wander_ten_times_run();
  const FitResult joint = fit_invariant_joint(average_positions(rec));
  EXPECT_TRUE(joint.noise.bias_instability);
  EXPECT_NE(joint.noise.how.find("from the full vector of the dwell means"), std::string::npos)
      << joint.noise.how;
  NormCalibrationOptions o;
  o.stability = false;
  const FitResult norm = calibrate_without_angles(raw_input_of(rec), o).fit.result;
  // It finds the wander itself (the bench: in every run at 10x); with the full vector of its
  // read-off attitudes it was taken from there, and its biases' z-variance rose to 4-15.
  EXPECT_TRUE(norm.noise.bias_instability) << norm.noise.how;
  EXPECT_EQ(norm.noise.how.find("full vector"), std::string::npos) << norm.noise.how;
}

// A wander the full vector shows evidently (2 delta log L above 5.99, chi2 with two
// parameters at P = 0.05) but below the bar of a finding is weighted for by the invariant
// fit too: from its own 32 rows it missed it more often, and its biases' z-variance under a
// wander of 1x the dwell error was 1.10-1.52 over 1000 runs (0.93-1.05 with the full
// vector's). This failed before (the joint fit estimated from its own rows).
TEST(FitNoise, AnEvidentWanderOfTheFullVectorBelowTheFindingBarWeightsTheJointFit) {
  int evident = 0;
  for (std::uint64_t seed = 1; seed <= 20; ++seed) {
    const std::vector<PositionAverage> avg = average_positions(wander_run(1, seed));
    const std::optional<FitNoiseChoice> full = full_vector_noise_choice(avg, FitNoiseOptions{});
    if (!full || full->noise.white() || full->finding.bias_instability || full->finding.lr <= 5.99)
      continue;
    ++evident;
    const FitResult joint = fit_invariant_joint(avg);
    EXPECT_NE(joint.noise.how.find("from the full vector"), std::string::npos)
        << "seed " << seed << ": " << joint.noise.how;
    EXPECT_FALSE(joint.noise.bias_instability) << "seed " << seed << ": not a finding";
  }
  EXPECT_GE(evident, 2) << "the seeds do not exercise the rule";
}

// With the correlation time given as one value, the joint fit takes any wander the full
// vector weights for, evident or not: under a 1x wander its biases were at 1.31-1.51 in
// z-variance over 1000 runs with the evident ones alone, 1.09-1.17 now (the full vector's
// own: 1.09-1.19). This failed before (below the bar the joint fit estimated from its own
// rows).
TEST(FitNoise, GivenTheCorrelationTimeTheJointFitTakesAnyWanderTheFullVectorWeightsFor) {
  FitNoiseOptions given, range;
  given.known_tau = KnownTau{300, 300};
  range.known_tau = KnownTau{150, 600};
  // Over seeds 1-20 of a 1x wander, the joint fit under `options` where the full vector
  // weights for a wander below the evident bar (2 delta log L <= 5.99): whether it took it.
  const auto weak_cases = [](const FitNoiseOptions& options) {
    std::vector<std::pair<std::uint64_t, bool>> taken;
    for (std::uint64_t seed = 1; seed <= 20; ++seed) {
      const std::vector<PositionAverage> avg = average_positions(wander_run(1, seed));
      const std::optional<FitNoiseChoice> full = full_vector_noise_choice(avg, options);
      if (!full || full->noise.white() || full->finding.bias_instability || full->finding.lr > 5.99)
        continue;
      const FitResult joint = fit_invariant_joint(avg, options);
      const bool took = joint.noise.how.find("from the full vector") != std::string::npos;
      EXPECT_TRUE(!took || joint.noise.wander_ug == full->finding.wander_ug) << "seed " << seed;
      taken.emplace_back(seed, took);
    }
    return taken;
  };
  const auto with_tau = weak_cases(given);
  EXPECT_GE(with_tau.size(), 2u) << "the seeds do not exercise the rule";
  for (const auto& [seed, took] : with_tau) EXPECT_TRUE(took) << "seed " << seed;
  // Told nothing of the correlation time, or a range of it, a weak one is not taken: the
  // joint fit then estimates from its own rows.
  for (const FitNoiseOptions& options : {FitNoiseOptions{}, range}) {
    const auto otherwise = weak_cases(options);
    EXPECT_GE(otherwise.size(), 1u) << "the seeds do not exercise the bar";
    for (const auto& [seed, took] : otherwise) EXPECT_FALSE(took) << "seed " << seed;
  }
}

// A white unit's classic24 run as `standcal simulate --program classic24 --dwell-s 10
// --rate-hz 25` makes it: re-mounted, 1928 s.
Recording white_classic24_run(std::uint64_t seed) {
  return test::simulate_default_run(classic24(), 10, 25, seed);
}

// A wander the joint fit's own 24 rows propose, below the bar of a finding, that the full vector's
// 72 rows of the same dwell means disfavour against white noise is not weighted for. On a white
// unit's classic24 runs the joint fit's own rows proposed wanders of 5-16 ug (tau 150-1200
// s) where the full vector saw none or a weaker one, and the biases' sigmas came out 9.6-25
// ug against white noise's 1.1; the full vector disfavoured those wanders by 3.9-21 in 2 delta
// log L. This failed before: 63 of the 300 bias sigmas of seeds 1-100 above 3x white noise's,
// z-variance 0.81 (6 and 0.94 with the check; 4 and 0.94 since the dwells are windows).
TEST(FitNoise, AWanderTheFullVectorDisfavoursIsNotWeightedByTheJointFit) {
  STANDCAL_STATISTICAL_TEST();
  const Eigen::Vector3d truth_g = default_truth().unit.bias_g;
  int inflated = 0, biases = 0;
  double z2 = 0;
  for (std::uint64_t seed = 1; seed <= 100; ++seed) {
    const std::vector<PositionAverage> avg = average_positions(white_classic24_run(seed));
    const FitResult joint = fit_invariant_joint(avg);
    const FitResult white = fit_invariant_joint(avg, white_noise_weighting());
    if (seed == 1)  // the own rows propose 9.2 ug at 1200 s; the full vector, white noise
      EXPECT_NE(joint.noise.how.find("which disfavour the wander the invariant rows estimate"),
                std::string::npos)
          << joint.noise.how;
    for (int axis = 0; axis < 3; ++axis) {
      const ParameterEstimate& b = joint.unit[static_cast<std::size_t>(axis)];
      if (*b.sigma > 3 * *white.unit[static_cast<std::size_t>(axis)].sigma) ++inflated;
      z2 += std::pow((*b.value - truth_g[axis]) / *b.sigma, 2);
      ++biases;
    }
  }
  std::printf(
      "joint fit, white classic24 runs: %d of %d bias sigmas above 3x white noise's, "
      "z-variance %.3f\n",
      inflated, biases, z2 / biases);
  EXPECT_LE(inflated, 12) << "bias sigmas above 3x white noise's, of " << biases;
  // 300 z's of an honest sigma: mean z^2 1 with sd 0.08.
  EXPECT_GT(z2 / biases, 0.75);
  EXPECT_LT(z2 / biases, 1.3);
}

// A full-vector model that does not fit the means (here 300 ug on the x axis following the
// outer angle, which no parameter of it has) is no source of the wander: its misfit would
// be taken for wander. The invariant fit then estimates from its own rows.
TEST(FitNoise, AFullVectorThatDoesNotFitIsNoSourceOfTheWander) {
  std::vector<PositionAverage> avg = average_positions(wander_ten_times_run());
  ASSERT_TRUE(full_vector_noise_choice(avg, FitNoiseOptions{}).has_value());
  for (PositionAverage& p : avg)
    p.mean_g[0] += 300 * kUg * std::sin(3 * p.alpha1_cmd_deg * kDegToRad);
  EXPECT_FALSE(full_vector_noise_choice(avg, FitNoiseOptions{}).has_value());
  const FitResult joint = fit_invariant_joint(avg);
  EXPECT_EQ(joint.noise.how.find("full vector"), std::string::npos) << joint.noise.how;
}

// A wander the full vector weights for below the bar of a finding is the noise its model is
// checked against, not white noise: under a wander the full model's chi-square against white
// noise alone fails, and the joint fit then set the full vector aside as a model that does
// not fit, estimated from its own rows, and weighted as white noise. Diagnostic32 under a 3x
// wander of tau 600 s, given, seeds 101-200: this failed before, the joint fit weighting as
// white in 2 of those 100 runs (seeds 138 and 170), its bias_x then 7.0 and 16.9 sigma off.
TEST(FitNoise, AWanderTheFullVectorWeighsForIsWhatItsModelIsCheckedAgainst) {
  STANDCAL_STATISTICAL_TEST();
  FitNoiseOptions given;
  given.known_tau = KnownTau{600, 600};
  int set_aside = 0, joint_white = 0, weighted = 0;
  for (std::uint64_t seed = 101; seed <= 200; ++seed) {
    const std::vector<PositionAverage> avg = average_positions(wander_run(3, seed, 600));
    const FitResult full = fit_full_vector(avg, given);
    if (full.noise.model == "white") continue;
    ++weighted;
    if (!full_vector_noise_choice(avg, given)) ++set_aside;
    const FitResult joint = fit_invariant_joint(avg, given);
    if (joint.noise.model == "white") {
      ++joint_white;
      const double z =
          (*joint.unit[0].value - default_truth().unit.bias_g[0]) / *joint.unit[0].sigma;
      std::printf("seed %llu: joint weighted as white, bias_x z %.1f, full lr %.2f\n",
                  static_cast<unsigned long long>(seed), z, full.noise.lr);
    }
  }
  std::printf("full vector weighted for a wander in %d of 100 runs; set aside %d; joint white %d\n",
              weighted, set_aside, joint_white);
  EXPECT_GT(weighted, 75);
  EXPECT_EQ(set_aside, 0);
  EXPECT_EQ(joint_white, 0);
}

// The norm fit's rows, one per interval, cannot tell white noise from a wander as large as a
// dwell mean's white error: under a 1x wander (tau 300 s, given) they found it in 69 of 1000
// runs, weighted most others as white, and the biases came out at 1.57-2.12 in z-variance
// (docs/calibration.md, Monte Carlo). Where the wander is no finding its sigmas are now
// averaged over the wander's sizes the run allows (FitNoiseOptions::average_over_wander_sizes).
// Over 200 runs the three biases' mean z^2 has sd about 0.15 at 1.85; these 200 gave 1.735
// before, which failed, and 1.159 since.
TEST(FitNoise, TheNormFitsSigmasAllowForAWanderItsRowsCannotExclude) {
  STANDCAL_STATISTICAL_TEST();
  const auto r = monte_carlo({"wander 1x", 1, 300}, kRunsUnpinnedWander);
  const noise_mc::ZStats& z = stats(r, "norm", "tau given");
  ASSERT_EQ(z.failed, 0);
  const double biases = (z.z2_mean[0] + z.z2_mean[1] + z.z2_mean[2]) / 3;
  std::printf("norm fit, 1x wander, tau given, %d runs: the biases' mean z-variance %.3f\n", z.runs,
              biases);
  EXPECT_LT(biases, 1.45) << "the norm fit's biases' mean z-variance";
  EXPECT_GT(biases, 0.6) << "the norm fit's biases' mean z-variance";
}

// What the norm fit's sigmas allow for is in its JSON and its report's Noise line, with what
// narrows them; the stand fits, whose full vector sees such a wander, do not average so.
TEST(FitNoise, TheNormReportSaysWhatWanderItsSigmasAllowFor) {
  const Recording rec = wander_run(0, 5);
  const RawInput raw = raw_input_of(rec);
  const NormCalibration norm = norm_fit_of(raw);
  const NoiseFinding& n = norm.fit.result.noise;
  ASSERT_FALSE(n.bias_instability) << n.how;
  EXPECT_GT(n.sigmas_allow_wander_up_to_ug, 0) << n.how;
  EXPECT_NE(n.how.find("cannot exclude"), std::string::npos) << n.how;
  const nlohmann::json j = norm_calibration_to_json(norm, raw);
  EXPECT_DOUBLE_EQ(j["noise"]["sigmas_allow_wander_up_to_ug"].get<double>(),
                   n.sigmas_allow_wander_up_to_ug)
      << j["noise"].dump(2);
  EXPECT_NE(format_norm_report(norm, raw).find(
                "that these intervals cannot exclude (give the unit's measured wander, "
                "--bias-instability-ug with --bias-instability-tau-s"),
            std::string::npos)
      << format_norm_report(norm, raw);
  EXPECT_EQ(fit_full_vector(average_positions(rec)).noise.sigmas_allow_wander_up_to_ug, 0);
}

// The norm fit's biases are conservative here by design (0.45-0.56 over 1000 runs: its sigmas
// allow for the wanders its rows cannot exclude), so for it the lower bound of 0.3 is about
// 2 sd below, not 3.5; these 40 seeds are fixed.
TEST(FitNoise, WhiteNoiseStaysWhiteAndHonest) {
  const auto r = monte_carlo({"white", 0, 300}, kRunsWhite);
  EXPECT_EQ(r.samples_correlated, 0);  // independent samples are not taken as correlated
  for (const char* estimator : {"full", "joint", "norm"}) {
    const noise_mc::ZStats& z = stats(r, estimator, "estimated");
    EXPECT_LE(z.wander_significant, 2) << estimator;
    expect_honest(z);
    EXPECT_GE(min_coverage(z), 0.8) << estimator;
  }
}

// A unit whose output filter correlates its samples over two sample periods (0.08 s at
// 25 Hz): sigma / sqrt(n) then understates a dwell mean's error by sqrt((1 + a) / (1 - a)) =
// 2.0 (a = exp(-1/2)). The stand fits' noise model took the excess scatter for a bias wander
// between dwells in all 40 runs (a false finding), and weighted for it the biases' sigmas
// came out twice too large (z-variance 0.21-0.26); the fits told the noise is white were 4x
// overconfident (1000 runs: docs/calibration.md). The norm fit, whose intervals take their
// errors from the Allan curve, was honest. The dwells' pooled Allan curves show the
// correlation, and each dwell mean's standard error is widened by it.
TEST(FitNoise, SamplesCorrelatedByTheUnitsOutputFilterWidenTheDwellErrors) {
  const auto r = monte_carlo({"white", 0, 300}, kRunsWhite, 1, 0.08);
  EXPECT_EQ(r.samples_correlated, kRunsWhite);
  for (const char* estimator : {"full", "joint", "norm"}) {
    const noise_mc::ZStats& z = stats(r, estimator, "estimated");
    EXPECT_LE(z.wander_significant, 2) << estimator;
    expect_honest(z);
    EXPECT_GE(min_coverage(z), 0.8) << estimator;
    expect_honest(stats(r, estimator, "white"));  // 3.9-4.8 before, over 1000 runs
  }
}

// Review of issue 21: a recording whose time stamps repeat has no sampling period; the
// fit's Allan figures are then absent, not a refused calibration.
TEST(FitNoise, ARecordingWithRepeatedTimeStampsHasNoAllanFiguresButIsFitted) {
  SimulationRequest req;
  req.program = diagnostic32();
  req.truth = default_truth();
  req.timing.dwell_s = 2;
  req.timing.sample_rate_hz = 10;
  Recording rec = simulate_run(req);
  rec.sample_rate_hz = kNoValue;
  for (RecordingSample& s : rec.samples) s.t_s = std::floor(s.t_s);  // ten samples per stamp
  EXPECT_FALSE(allan_finding(rec).has_value());
  EXPECT_NO_THROW(fit_full_vector(average_positions(rec)));
}

namespace {

// The paper's nine positions with 2 s dwells: about a minute, and for the joint fit as many
// measurements as unknowns.
Recording short_paper9_run() {
  SimulationRequest req;
  req.program = load_program("paper9");
  req.truth = default_truth();
  req.timing.dwell_s = 2;
  req.timing.sample_rate_hz = 10;
  return simulate_run(req);
}

}  // namespace

// Review of issue 21: nine positions leave the joint fit no residual to estimate a wander
// from; the report says it was not estimated rather than that none was found.
TEST(FitNoise, TooFewMeasurementsSayTheWanderWasNotEstimated) {
  const Recording rec = short_paper9_run();
  const FitResult fit = fit_invariant_joint(average_positions(rec));
  EXPECT_EQ(fit.noise.model, "white");
  EXPECT_EQ(fit.noise.lr_threshold, 0) << fit.noise.how;
  const std::string report = format_report(fit, report_context(rec, average_positions(rec)));
  EXPECT_NE(report.find("too few measurements"), std::string::npos) << report;
  EXPECT_EQ(report.find("no bias wander between dwells"), std::string::npos) << report;
}

// Too few measurements to estimate a wander, but the unit's is specified with its correlation
// time known as a range: weighted at the range's log-middle and the biases' variance averaged
// over the range, as where the run is long enough but shows none. (It took the range's lower
// end as one time before, where the biases' sigmas are smallest.)
TEST(FitNoise, TooFewMeasurementsTakeTheSpecifiedWanderOverTheGivenRange) {
  const std::vector<PositionAverage> avg = average_positions(short_paper9_run());
  const auto fit_given = [&](KnownTau tau) {
    FitNoiseOptions o;
    o.specified = {Vec3::Constant(5 * kUg), tau.min_s};
    o.known_tau = tau;
    return fit_invariant_joint(avg, o);
  };
  // Times short against the run (about a minute): a wander much slower would be an offset
  // the biases take whole, the same at every time.
  const KnownTau range{10, 40};
  const FitResult over_range = fit_given(range);
  EXPECT_EQ(over_range.noise.source, "specified") << over_range.noise.how;
  EXPECT_NE(over_range.noise.how.find("too few measurements"), std::string::npos);
  EXPECT_NE(over_range.noise.how.find("at the given correlation times 10-40 s, the sigmas "
                                      "averaged over them"),
            std::string::npos)
      << over_range.noise.how;
  EXPECT_DOUBLE_EQ(over_range.noise.tau_s, 20);
  EXPECT_DOUBLE_EQ(over_range.noise.tau_given_max_s, 40);
  // Each variance the average over the range's five times, or the middle's where larger.
  const auto variance_at = [&](double tau_s, std::size_t j) {
    const double s = *fit_given({tau_s, tau_s}).unit[j].sigma;
    return s * s;
  };
  for (std::size_t j = 0; j < kUnitParameterCount; ++j) {
    if (!over_range.unit[j].sigma) continue;
    double mean = 0;
    for (const double tau_s : range.grid_s()) mean += variance_at(tau_s, j) / 5;
    const double expected = std::sqrt(std::max(mean, variance_at(20, j)));
    EXPECT_NEAR(*over_range.unit[j].sigma, expected, 1e-6 * expected) << kUnitParameterNames[j];
  }
  for (std::size_t bias = 0; bias < 3; ++bias)
    EXPECT_GT(*over_range.unit[bias].sigma, std::sqrt(variance_at(20, bias)))
        << kUnitParameterNames[bias];
}

// The unit's wander given (its size and correlation time, from a long static recording or
// the data sheet) and a run that shows one like it: the fit weights with the given wander,
// as a fit told it outright does, and says the run agrees; the run's own estimate, a finding
// selected for being large and widened for its own uncertainty, had made a 1x wander's biases
// conservative (bench/noise "unit given": 0.81-0.83 in z-variance, full fit). Failed before:
// the source was "estimated" and the wander the run's own. A given size the run departs from
// (a tenth of the simulated one) gives way to the run's.
TEST(FitNoise, AGivenWanderTheRunAgreesWithIsWhatTheFitWeightsWith) {
  const Recording rec = wander_ten_times_run();
  const std::vector<PositionAverage> avg = average_positions(rec);
  const double tau_s = default_truth().noise.bias_instability_tau_s;
  const double wander_ug = 10 * default_truth().noise.density_ug_rthz / std::sqrt(10.0);
  const auto fit_given = [&](double size_ug, FitNoiseOptions::Mode mode) {
    FitNoiseOptions o;
    o.mode = mode;
    o.specified = {Vec3::Constant(size_ug * kUg), tau_s};
    o.known_tau = KnownTau{tau_s, tau_s};
    return fit_full_vector(avg, o);
  };
  const FitResult agrees = fit_given(wander_ug, FitNoiseOptions::Mode::estimate);
  const FitResult told = fit_given(wander_ug, FitNoiseOptions::Mode::specified);
  EXPECT_TRUE(agrees.noise.bias_instability) << agrees.noise.how;
  EXPECT_EQ(agrees.noise.source, "specified") << agrees.noise.how;
  EXPECT_NE(agrees.noise.how.find("consistent with the specified bias instability"),
            std::string::npos)
      << agrees.noise.how;
  for (int a = 0; a < 3; ++a) EXPECT_DOUBLE_EQ(agrees.noise.wander_ug[a], wander_ug);
  for (std::size_t j = 0; j < kUnitParameterCount; ++j) {
    if (!told.unit[j].sigma) continue;
    EXPECT_DOUBLE_EQ(*agrees.unit[j].sigma, *told.unit[j].sigma) << kUnitParameterNames[j];
  }
  const std::string agreeing_report = format_report(agrees, report_context(rec, avg));
  EXPECT_NE(agreeing_report.find("this run shows one that agrees"), std::string::npos);
  // The report advises giving the unit's measured wander only where the fit weighed with one
  // estimated from the run alone.
  EXPECT_EQ(agreeing_report.find("give the unit's"), std::string::npos) << agreeing_report;
  const FitResult alone = fit_full_vector(avg, FitNoiseOptions{});
  ASSERT_EQ(alone.noise.source, "estimated") << alone.noise.how;
  EXPECT_NE(format_report(alone, report_context(rec, avg))
                .find("the sigmas rest on a wander estimated from this run alone"),
            std::string::npos);

  const FitResult departs = fit_given(wander_ug / 10, FitNoiseOptions::Mode::estimate);
  EXPECT_EQ(departs.noise.source, "estimated") << departs.noise.how;
  EXPECT_NE(departs.noise.how.find("departs from the specified bias instability"),
            std::string::npos)
      << departs.noise.how;
  EXPECT_GT(departs.noise.wander_ug.minCoeff(), 3 * wander_ug / 10) << departs.noise.how;
}

// A long dwell whose samples have gaps (a quarter of its time, in 0.25 s every second: what
// standcald's dwells held before its chunks continued each other) shows a wander of 60 s as a
// shorter one, since its curves take the samples as evenly spaced: no wander is read off it,
// in memory or streamed, and the recording's warnings say why. Without the check its curves
// gave a wander to the fits (this test failed so).
TEST(FitNoise, ALongDwellWithGapsGivesNoWander) {
  SimulationRequest req;
  req.program = diagnostic32();
  req.truth = default_truth();
  req.truth.noise.bias_instability_ug = 3 * req.truth.noise.density_ug_rthz / std::sqrt(10.0);
  req.truth.noise.bias_instability_tau_s = 60;
  req.timing.dwell_s = 10;
  req.timing.sample_rate_hz = 25;
  req.seed = 21;
  req.program.positions.front().dwell_s = 1800;
  Recording rec = simulate_run(req);
  // Receive-time jitter is no gap: every other sample of the long dwell 0.6 periods late
  // leaves its wander as it was.
  Recording jittered = rec;
  for (std::size_t i = 1; i + 1 < jittered.samples.size(); i += 2)
    if (jittered.samples[i].pos == 0 && jittered.samples[i + 1].pos == 0)
      jittered.samples[i].t_s += 0.6 / req.timing.sample_rate_hz;
  const AveragedRecording late = average_recording(jittered);
  ASSERT_TRUE(late.allan.has_value());
  EXPECT_TRUE(late.allan->wander.has_value()) << late.allan_warning;
  EXPECT_EQ(late.allan_warning, "");
  EXPECT_GT(dwell_allan(jittered).gaps.count, 1000u);  // steps of 1.6 periods, cancelled by 0.4

  const double first_s = rec.samples.front().t_s;
  std::erase_if(rec.samples, [&](const RecordingSample& x) {
    return x.pos == 0 && std::fmod(x.t_s - first_s, 1.0) >= 0.75;
  });
  const AveragedRecording averaged = average_recording(rec);
  ASSERT_TRUE(averaged.allan.has_value());
  EXPECT_FALSE(averaged.allan->wander.has_value())
      << "tau " << averaged.allan->wander->tau_min_s << "-" << averaged.allan->wander->tau_max_s;
  EXPECT_NE(averaged.allan_warning.find("gaps"), std::string::npos) << averaged.allan_warning;
  FitNoiseOptions noise;
  EXPECT_FALSE(take_recording_wander(noise, averaged.allan));
  test::TempDir dir{"standcal-gaps"};
  write_recording(rec, dir.file("gaps.csv"));
  const RecordingDigest digest = digest_recording(dir.file("gaps.csv"));
  ASSERT_TRUE(digest.allan.has_value());
  EXPECT_FALSE(digest.allan->wander.has_value());
  const DwellAllan in_memory = dwell_allan(rec);
  EXPECT_GT(in_memory.gaps.count, 1000u);
  EXPECT_EQ(digest.allan->gaps.count, in_memory.gaps.count);
  EXPECT_NE(digest.allan_warning().find("gaps"), std::string::npos) << digest.allan_warning();

  // The same recording without its angles: the norm fit's static intervals and `standcal
  // noise`'s (found by the detector, as in another tool's file) count the same gaps from the
  // samples' time stamps, and read no wander off their curves either.
  const RawInput raw = raw_input_of(rec);
  NormCalibrationOptions norm_options;
  norm_options.stability = false;
  const NormCalibration norm = calibrate_without_angles(raw, norm_options);
  EXPECT_EQ(norm.detection.gaps.count, in_memory.gaps.count);
  ASSERT_TRUE(norm.fit.result.noise.allan.has_value());
  EXPECT_FALSE(norm.fit.result.noise.allan->wander.has_value());
  EXPECT_NE(norm.fit.result.noise.unit_wander_from, kWanderFromRecording);
  EXPECT_NE(gaps_warning(norm, raw).find("the static intervals' samples miss"), std::string::npos)
      << gaps_warning(norm, raw);
  EXPECT_NE(
      std::find(norm.notes.begin(), norm.notes.end(), norm.fit.result.noise.allan->gaps_warning),
      norm.notes.end());
  RawInput other_tools = raw;
  other_tools.block.clear();
  const StaticNoise detected = static_noise(other_tools);
  EXPECT_GT(detected.allan.gaps.count, 1000u);
  EXPECT_TRUE(detected.allan.gaps.too_much()) << detected.allan.gaps.missing_share();
  // Without the gaps, the same two read the long dwell's wander.
  const NormCalibration whole =
      calibrate_without_angles(raw_input_of(simulate_run(req)), norm_options);
  EXPECT_EQ(whole.detection.gaps.count, 0u);
  EXPECT_EQ(whole.fit.result.noise.unit_wander_from, kWanderFromRecording);
  EXPECT_EQ(gaps_warning(whole, raw), "");
}

// A calibration recording that holds its first position long enough to show the wander turn
// over (a warm-up) gives its fits the unit's wander by itself: the dwells' pooled Allan curves
// pin its size and correlation time, and with nothing of the unit's given the fits weigh with
// that as with a given wander (take_recording_wander), and say so; the diagnosis of the same
// recording tests against the same. Without the long dwell the run's own estimate stands.
TEST(FitNoise, ALongDwellInTheRecordingGivesTheFitsTheUnitsWander) {
  constexpr double kTauS = 60, kWarmupS = 1800;
  SimulationRequest req;
  req.program = diagnostic32();
  req.truth = default_truth();
  req.truth.noise.bias_instability_ug = 3 * req.truth.noise.density_ug_rthz / std::sqrt(10.0);
  req.truth.noise.bias_instability_tau_s = kTauS;
  req.timing.dwell_s = 10;
  req.timing.sample_rate_hz = 25;
  req.seed = 21;
  const AveragedRecording plain = average_recording(simulate_run(req));
  ASSERT_TRUE(plain.allan.has_value());
  EXPECT_FALSE(plain.allan->wander.has_value()) << "10 s dwells cannot pin a 60 s wander";
  FitNoiseOptions nothing_given;
  EXPECT_FALSE(take_recording_wander(nothing_given, plain.allan));

  req.program.positions.front().dwell_s = kWarmupS;
  const Recording rec = simulate_run(req);
  const AveragedRecording averaged = average_recording(rec);
  ASSERT_TRUE(averaged.allan && averaged.allan->wander) << "a 30-minute dwell pins it";
  const WanderToGive& w = *averaged.allan->wander;
  EXPECT_LE(w.tau_min_s, kTauS);
  EXPECT_GE(w.tau_max_s, kTauS);
  EXPECT_LE(w.q_min, req.truth.noise.bias_instability_ug);
  EXPECT_GE(w.q_max, req.truth.noise.bias_instability_ug);

  FitNoiseOptions noise;
  ASSERT_TRUE(take_recording_wander(noise, averaged.allan));
  EXPECT_EQ(noise.specified_from, kWanderFromRecording);
  const FitResult fit = fit_full_vector(averaged.averages, noise);
  EXPECT_EQ(fit.noise.unit_wander_from, kWanderFromRecording) << fit.noise.how;
  EXPECT_EQ(fit.noise.source, "specified") << fit.noise.how;
  // Each axis with its own size, the largest of which is the one the words give.
  ASSERT_EQ(w.q_axes.size(), 3u);
  for (int a = 0; a < 3; ++a)
    EXPECT_DOUBLE_EQ(fit.noise.wander_ug[a], w.q_axes[static_cast<std::size_t>(a)]);
  EXPECT_DOUBLE_EQ(fit.noise.wander_ug.maxCoeff(), w.q);
  EXPECT_EQ(fit_to_json(fit)["noise"]["unit_wander_from"], "recording");
  const std::string report = format_report(fit, report_context(rec, averaged.averages));
  EXPECT_NE(report.find("the unit's bias wander as this recording's long dwell shows it"),
            std::string::npos)
      << report;
  EXPECT_EQ(report.find("give the unit's"), std::string::npos) << report;
  // Curves that end before the Allan peak of the longest correlation time they allow (1.89 x
  // it) give nothing, nor do correlation times of seconds: without these checks pooled 10 s
  // dwells had given a wander in 13 and 2 of 1000 runs of bench/noise at 10x (tau 60 and
  // 300 s); both expectations fail without them. Curves past that time but short of its peak
  // were taken until 2026-12-07 (the second expectation failed then).
  std::optional<AllanFinding> short_curves = averaged.allan;
  short_curves->wander->curves_end_s = 0.9 * short_curves->wander->tau_max_s;
  FitNoiseOptions beyond_the_end;
  EXPECT_FALSE(take_recording_wander(beyond_the_end, short_curves));
  short_curves->wander->curves_end_s = 1.5 * short_curves->wander->tau_max_s;
  FitNoiseOptions short_of_the_peak;
  EXPECT_FALSE(take_recording_wander(short_of_the_peak, short_curves));
  short_curves->wander->curves_end_s =
      kGaussMarkovAllanPeakPerTau * short_curves->wander->tau_max_s;
  FitNoiseOptions at_the_peak;
  EXPECT_TRUE(take_recording_wander(at_the_peak, short_curves));
  short_curves->wander->tau_min_s = 1;
  short_curves->wander->tau_max_s = 3;
  short_curves->wander->curves_end_s = 3.3;
  FitNoiseOptions of_seconds;
  EXPECT_FALSE(take_recording_wander(of_seconds, short_curves));
  // A wander the operator gives is not overridden by the recording's.
  FitNoiseOptions given;
  given.specified = {Vec3::Constant(2 * w.q * kUg), kTauS};
  given.known_tau = KnownTau{kTauS, kTauS};
  EXPECT_FALSE(take_recording_wander(given, averaged.allan));
  EXPECT_TRUE(given.specified_from.empty());

  const Diagnosis d = diagnose_recording(rec);
  EXPECT_EQ(d.noise.unit_wander_from, kWanderFromRecording) << d.noise.how;
  EXPECT_EQ(d.noise.model, "gauss_markov") << d.noise.how;
  EXPECT_DOUBLE_EQ(d.noise.wander_ug.maxCoeff(), w.q) << d.noise.how;

  // The same recording without its angles: the norm fit finds the long dwell among its
  // static intervals, and it and the attitude-free diagnosis take its wander too.
  const RawInput raw = raw_input_of(rec);
  NormCalibrationOptions norm_options;
  norm_options.stability = false;
  const NormCalibration norm = calibrate_without_angles(raw, norm_options);
  EXPECT_EQ(norm.fit.result.noise.unit_wander_from, kWanderFromRecording)
      << norm.fit.result.noise.how;
  const Diagnosis without_angles = diagnose_without_angles(raw, norm, {});
  EXPECT_EQ(without_angles.noise.unit_wander_from, kWanderFromRecording)
      << without_angles.noise.how;

  // A wander the header says the run was made with (standcald's unit.bias_instability_*) comes
  // before the long dwell's, in the fits, the diagnosis and the norm fit alike; an operator's
  // weighting before both.
  GivenWander configured;
  configured.size_ug = 2 * w.q;
  configured.known_tau = KnownTau{kTauS, kTauS};
  Recording made_with = rec;
  set_unit_wander_header(made_with, configured);
  FitNoiseOptions header_first;
  ASSERT_TRUE(take_unit_wander(header_first, made_with, averaged.allan, std::nullopt));
  EXPECT_EQ(header_first.specified_from, kWanderFromHeader);
  EXPECT_DOUBLE_EQ(header_first.specified.q_g[0], 2 * w.q * kUg);
  FitNoiseOptions told_white = white_noise_weighting();
  EXPECT_FALSE(take_unit_wander(told_white, made_with, averaged.allan, std::nullopt));
  EXPECT_EQ(diagnose_recording(made_with).noise.unit_wander_from, kWanderFromHeader);
  RawInput raw_made_with = raw_input_of(made_with);
  raw_made_with.recording = made_with;
  EXPECT_EQ(calibrate_without_angles(raw_made_with, norm_options).fit.result.noise.unit_wander_from,
            kWanderFromHeader);
}

namespace {

// The median over intervals and axes of an interval's error over sigma / sqrt(n): `curve`, the
// pooled Allan curve's at its length, else the one the fit weighted it with.
double median_error_over_white(const std::vector<StaticInterval>& intervals, bool curve) {
  std::vector<double> r;
  for (const StaticInterval& iv : intervals)
    for (int a = 0; a < 3; ++a)
      r.push_back((curve ? iv.curve_standard_error[a] : iv.standard_error[a]) /
                  iv.white_standard_error[a]);
  std::nth_element(r.begin(), r.begin() + static_cast<std::ptrdiff_t>(r.size() / 2), r.end());
  return r[r.size() / 2];
}

// A seed whose two-hour warm-up sees a 1200 s wander of 3x the dwell error and does not pin it
// (most do not: bench/noise/allan_tau_main.cpp bounds its correlation time in about 1 of 5),
// and whose run alone favours a correlation time below the floor the curves put under it; its
// rows show the wander at the floor's times (a finding), so the floor stands.
constexpr std::uint64_t kUnpinnedWarmUpSeed = 9;
// A two-hour static recording of a 10x wander of 1200 s whose curves see it and pin none
// (unit_static_recording), and a quarter-hour run of the same wander whose rows show it and,
// alone, favour correlation times below the recording's floor.
constexpr unsigned kSlowStaticRecordingSeed = 42;
constexpr std::uint64_t kSlowRunSeed = 3;
// The same, but its rows show the wander there only below the bar of a finding.
constexpr std::uint64_t kUnpinnedWarmUpBelowBarSeed = 14;

// One run of bench/noise (its truth_for: one rigid fixture) with a warm-up of `warmup_s`
// (the programme's warmup_s) and a wander `times` the white error of a dwell mean, of
// correlation time `tau_s`.
Recording bench_run_with_warm_up(double warmup_s, double times, double tau_s, std::uint64_t seed) {
  SimulationRequest req;
  req.program = diagnostic32();
  req.program.warmup_s = warmup_s;
  req.truth = default_truth();
  for (Vec3& m : req.truth.stand.mounting_rad)
    m = req.truth.stand.mounting_rad[static_cast<std::size_t>(Mount::x)];
  req.truth.noise.bias_instability_ug = times * req.truth.noise.density_ug_rthz / std::sqrt(10.0);
  req.truth.noise.bias_instability_tau_s = tau_s;
  req.timing.dwell_s = 10;
  req.timing.sample_rate_hz = 25;
  req.seed = seed;
  return simulate_run(req);
}

// The norm fit of `rec` without its angles, nothing of the unit's given: it takes the wander
// the warm-up's curves pin.
NormCalibration norm_fit_taking_the_warm_ups_wander(const Recording& rec) {
  NormCalibration norm = norm_fit_of(raw_input_of(rec));
  EXPECT_EQ(norm.fit.result.noise.unit_wander_from, kWanderFromRecording)
      << norm.fit.result.noise.how;
  return norm;
}

}  // namespace

// A warm-up pins the unit's wander (take_recording_wander) and the norm fit weights for it
// between its intervals, by GLS. An interval's own error is then the pooled curve's at its
// length less that wander's share, which for white noise and a wander alone is sigma /
// sqrt(n), and the norm fit's sigmas are the stand's invariant fit's of the same recording
// weighted for the same wander. Until 2026-12-06 the curve's whole was taken, so the wander
// counted twice: at 10x here the intervals' errors were 3.3 sigma / sqrt(n), and the norm
// fit's sigmas 2-12 % larger than the invariant's (both checks fail so); over 1000 runs of
// bench/noise (--warmup-hours 1 --tau-s 60) its z-variance fell to 0.78 (docs/calibration.md,
// "Monte Carlo").
TEST(FitNoise, ANormFitCountsTheWanderBetweenItsIntervalsOnce) {
  const Recording rec = bench_run_with_warm_up(3600, 10, 60, 23);
  const NormCalibration norm = norm_fit_taking_the_warm_ups_wander(rec);
  const NoiseFinding& n = norm.fit.result.noise;
  ASSERT_EQ(n.model, "gauss_markov") << n.how;
  const double curve = median_error_over_white(norm.detection.intervals, true);
  const double weighted = median_error_over_white(norm.detection.intervals, false);
  EXPECT_GT(curve, 2.5) << "the curves hold the wander's share";
  // What is left is the curve's variance less the wander's share, a difference of two numbers
  // ten times its size: a curve 4 % above the model's (3.17 against 3.04 x white here) leaves
  // 1.2 x white. Until each axis took its own size (2026-12-07) the largest axis's was taken
  // off every axis, which left less than white noise's and was floored at it: exactly 1.
  EXPECT_GE(weighted, 1) << norm.detection.standard_errors_how;
  EXPECT_LT(weighted, 1.5) << norm.detection.standard_errors_how;
  EXPECT_NE(norm.detection.standard_errors_how.find("less the share of the bias wander"),
            std::string::npos)
      << norm.detection.standard_errors_how;

  const AveragedRecording averaged = average_recording(rec);
  FitNoiseOptions noise;
  ASSERT_TRUE(take_recording_wander(noise, averaged.allan));
  const FitResult invariant = fit_invariant_joint(averaged.averages, noise);
  for (std::size_t k = 0; k < kUnitParameterCount; ++k) {
    const ParameterEstimate& a = invariant.unit[k];
    const ParameterEstimate& b = norm.fit.result.unit[k];
    ASSERT_TRUE(a.sigma && b.sigma) << kUnitParameterNames[k];
    EXPECT_NEAR(*b.sigma / *a.sigma, 1, 0.03) << kUnitParameterNames[k];
  }
}

// An hour's warm-up that shows no wander excludes one its curves would show, which the run's
// intervals, one row each, cannot: the wander the norm fit's sigmas allow for is weighed by
// both (FitNoiseOptions::wander_curves_ug), and is smaller than the intervals' alone allow.
// Before the curves were weighed the fit allowed what the rows alone do, and the first check
// below failed.
TEST(FitNoise, AWarmUpThatShowsNoWanderBoundsTheOneTheNormFitsSigmasAllowFor) {
  const Recording rec = bench_run_with_warm_up(3600, 0, 300, 1);
  const RawInput raw = raw_input_of(rec);
  const NormCalibration norm = norm_fit_of(raw);
  const NoiseFinding& n = norm.fit.result.noise;
  ASSERT_FALSE(n.bias_instability) << n.how;
  ASSERT_TRUE(n.allan && n.allan->wander_curves) << n.how;
  std::vector<StaticInterval> intervals = norm.detection.intervals;
  const NormFit rows_alone = fit_norm(intervals, raw.g_mps2, raw.units, NormFitOptions{});
  const NoiseFinding& m = rows_alone.result.noise;
  std::printf("the sigmas allow for a wander of up to %.3g ug (the intervals alone: %.3g ug)\n",
              n.sigmas_allow_wander_up_to_ug, m.sigmas_allow_wander_up_to_ug);
  EXPECT_LT(n.sigmas_allow_wander_up_to_ug, 0.5 * m.sigmas_allow_wander_up_to_ug) << n.how;
  EXPECT_GT(n.sigmas_allow_wander_up_to_ug, 0) << n.how;
  for (std::size_t k = 0; k < 3; ++k) {
    std::printf("%s: sigma %.3g ug (the intervals alone: %.3g ug)\n", kUnitParameterNames[k].data(),
                *norm.fit.result.unit[k].sigma / kUg, *rows_alone.result.unit[k].sigma / kUg);
    EXPECT_LT(*norm.fit.result.unit[k].sigma, *rows_alone.result.unit[k].sigma)
        << kUnitParameterNames[k];
  }
  EXPECT_TRUE(n.sigmas_allowance_weighs_allan_curves);
  EXPECT_FALSE(m.sigmas_allowance_weighs_allan_curves);
  EXPECT_NE(n.how.find("this run and its Allan curves cannot exclude"), std::string::npos) << n.how;
  EXPECT_TRUE(norm_calibration_to_json(norm, raw)["noise"]["sigmas_allowance_weighs_allan_curves"]
                  .get<bool>());
  EXPECT_NE(format_norm_report(norm, raw).find("that these intervals and their Allan curves "
                                               "cannot exclude"),
            std::string::npos)
      << format_norm_report(norm, raw);
}

// A warm-up still settling after power-on (30 ug e^(-t / 1200 s) from the first sample; the
// intervals two hours later quiet) shows in its curves as a large slow wander that the
// intervals do not have: curves that see a wander they do not pin are no bound on it.
// Weighed, such curves took the norm fit's biases under white noise to 0.11-0.15 in
// z-variance (bench/noise --runs 300 --warmup-hours 2 --warmup-transient-ug 30), and the
// first check below failed.
TEST(FitNoise, AWarmUpStillSettlingIsNoBoundOnTheWander) {
  Recording rec = bench_run_with_warm_up(7200, 0, 300, 1);
  noise_mc::Setup settling;
  settling.warmup_transient_ug = 30;
  noise_mc::add_warmup_transient(rec, settling);
  const NormCalibration norm = norm_fit_of(raw_input_of(rec));
  const NoiseFinding& n = norm.fit.result.noise;
  ASSERT_TRUE(n.allan) << n.how;
  EXPECT_FALSE(n.allan->wander_curves) << n.how;
  EXPECT_FALSE(n.sigmas_allowance_weighs_allan_curves) << n.how;
  EXPECT_GT(n.sigmas_allow_wander_up_to_ug, 0) << n.how;
}

namespace {

// kRunsWarmedUpWhite seeded runs of diagnostic32 (bench/noise's first table's programme).
noise_mc::Setup seeded_white_runs() {
  noise_mc::Setup setup;
  setup.program = diagnostic32();
  setup.runs = kRunsWarmedUpWhite;
  setup.first_seed = 7000;
  return setup;
}

// Under white noise, the norm fit's `weighting` rows over the runs of `r`: the three biases'
// mean z-variance must be white noise's (sd about 0.09 at 1 over 100 runs).
void expect_norm_biases_honest_under_white_noise(const noise_mc::ScenarioResult& r,
                                                 const std::string& weighting,
                                                 const std::string& what) {
  const noise_mc::ZStats& z = stats(r, "norm", weighting);
  ASSERT_EQ(z.failed, 0);
  const double biases = (z.z2_mean[0] + z.z2_mean[1] + z.z2_mean[2]) / 3;
  std::printf("norm fit, white noise, %s, %d runs: the biases' mean z-variance %.3f\n",
              what.c_str(), z.runs, biases);
  EXPECT_GT(biases, 0.75) << "the norm fit's biases' mean z-variance";
  EXPECT_LT(biases, 1.3) << "the norm fit's biases' mean z-variance";
}

// The same of the full and joint fits, over the runs of `r` each weighted for a wander (under
// white noise all below the bar of a finding: the subset whose sigmas the curves' bound sets,
// take_wander_curves). About 15-25 runs of 100: sd about 0.2-0.3 at 1.
void expect_stand_runs_weighted_for_a_wander_honest(const noise_mc::ScenarioResult& r,
                                                    const std::string& weighting,
                                                    const std::string& what) {
  for (const std::string estimator : {"full", "joint"}) {
    const noise_mc::ZStats& z = stats(r, estimator, weighting);
    ASSERT_EQ(z.failed, 0);
    const int runs = z.runs_by_weighting[1];
    ASSERT_GE(runs, 5) << estimator << ": the runs weighted for a wander below the bar";
    const std::array<double, 3>& sum = z.bias_z2_by_weighting[1];
    const double weighted_for = (sum[0] + sum[1] + sum[2]) / (3.0 * runs);
    std::printf(
        "%s fit, white noise, %s: the biases' mean z-variance %.3f over the %d runs "
        "weighted for a wander\n",
        estimator.c_str(), what.c_str(), weighted_for, runs);
    EXPECT_GT(weighted_for, 0.5) << estimator;
    EXPECT_LT(weighted_for, 2.0) << estimator;
  }
}

}  // namespace

// Over runs: white noise after an hour's warm-up, nothing given. The norm fit's biases were at
// 0.49-0.63 in z-variance over 300 runs of bench/noise (--runs 300 --warmup-hours 1), their
// sigmas allowing for the wanders its intervals alone cannot exclude; weighed by the warm-up's
// curves too, 0.96-1.05. These 100 seeds: the three biases' mean z-variance 0.572 before,
// which failed, and 1.098 since (sd about 0.09 at 1).
// The stand fits take the warm-up's curves too (take_recording_wander_or_bound): the runs they
// weighted for a wander below the bar were at 0.09-0.29 over those 300 runs. These seeds, over
// the runs so weighted: 0.165 (full, 19 runs) and 0.154 (joint, 18) with the bound undone,
// which fail, and 0.778 and 1.139 since.
TEST(FitNoise, AfterAWarmUpEveryFitsSigmasAreWhiteNoisesUnderWhiteNoise) {
  STANDCAL_STATISTICAL_TEST();
  noise_mc::Setup setup = seeded_white_runs();
  setup.warmup_hours = 1;
  setup.program.warmup_s = 3600;
  const auto r = noise_mc::run_scenario(setup, {"white", 0, 300});
  expect_norm_biases_honest_under_white_noise(r, "estimated", "a 1 h warm-up");
  expect_stand_runs_weighted_for_a_wander_honest(r, "estimated", "a 1 h warm-up");
}

namespace {

// A seeded static recording of the default unit as the bench draws it (noise_mc), `hours` long
// at 10 Hz with a wander `times` the white error of a 10 s dwell mean (correlation time tau_s),
// as raw input in m/s^2. (tests/support's unit_static_recording is a simulated stand run.)
std::shared_ptr<const RawInput> bench_static_recording(double hours, double times, double tau_s,
                                                       unsigned seed) {
  const TruthModel truth = default_truth();
  const double q_ug = times * truth.noise.density_ug_rthz / std::sqrt(10.0);
  auto in = std::const_pointer_cast<RawInput>(noise_mc::static_raw_input(
      simulate_static_gauss_markov(truth.noise.density_ug_rthz, q_ug, tau_s, hours * 3600,
                                   noise_mc::kStaticRecordingRateHz, seed),
      noise_mc::kStaticRecordingRateHz, truth.g_local_mps2));
  in->source = "unit-static.csv";
  return in;
}

// The norm fit of `raw` given the unit's static recording, nothing else of the unit's.
NormCalibration norm_fit_with_static(const RawInput& raw,
                                     std::shared_ptr<const RawInput> unit_static) {
  NormCalibrationOptions options;
  options.stability = false;
  options.unit_static_recording = std::move(unit_static);
  return calibrate_without_angles(raw, options);
}

}  // namespace

// A separate static recording of the unit that shows no wander bounds the wander the norm
// fit's sigmas allow for, as a warm-up inside the recording does: two hours of white noise,
// given with a quarter-hour run that has no warm-up. Without it the fit allows what its rows
// alone cannot exclude (the first check compares the two).
TEST(FitNoise, AStaticRecordingThatShowsNoWanderBoundsTheOneTheNormFitsSigmasAllowFor) {
  const Recording rec = bench_run_with_warm_up(0, 0, 300, 1);
  const RawInput raw = raw_input_of(rec);
  const NormCalibration alone = norm_fit_of(raw);
  const NormCalibration norm = norm_fit_with_static(raw, bench_static_recording(2, 0, 300, 11));
  const NoiseFinding& n = norm.fit.result.noise;
  const NoiseFinding& m = alone.fit.result.noise;
  ASSERT_FALSE(n.bias_instability) << n.how;
  std::printf("the sigmas allow for a wander of up to %.3g ug (the intervals alone: %.3g ug)\n",
              n.sigmas_allow_wander_up_to_ug, m.sigmas_allow_wander_up_to_ug);
  EXPECT_LT(n.sigmas_allow_wander_up_to_ug, 0.5 * m.sigmas_allow_wander_up_to_ug) << n.how;
  for (std::size_t k = 0; k < 3; ++k) {
    std::printf("%s: sigma %.3g ug (the intervals alone: %.3g ug)\n", kUnitParameterNames[k].data(),
                *norm.fit.result.unit[k].sigma / kUg, *alone.fit.result.unit[k].sigma / kUg);
    EXPECT_LT(*norm.fit.result.unit[k].sigma, *alone.fit.result.unit[k].sigma)
        << kUnitParameterNames[k];
  }
  ASSERT_TRUE(norm.unit_static_recording);
  EXPECT_EQ(norm.unit_static_recording->gave, "bound") << norm.unit_static_recording->why;
  EXPECT_NEAR(norm.unit_static_recording->static_s, 7200, 1);
  EXPECT_FALSE(alone.unit_static_recording);
  EXPECT_EQ(n.sigmas_allowance_allan_curves_from, kWanderFromStaticRecording);
  EXPECT_NE(n.how.find("this run and the unit's static recording cannot exclude"),
            std::string::npos)
      << n.how;
  const nlohmann::json j = norm_calibration_to_json(norm, raw);
  EXPECT_EQ(j["noise"]["sigmas_allowance_allan_curves_from"], "static_recording") << j["noise"];
  EXPECT_EQ(j["unit_static_recording"]["gave"], "bound") << j["unit_static_recording"];
  const std::string report = format_norm_report(norm, raw);
  EXPECT_NE(report.find("that these intervals and the unit's static recording cannot exclude\n"),
            std::string::npos)
      << report;
  EXPECT_NE(report.find("the unit's static recording unit-static.csv (2 h static) gave a bound "
                        "on the wander: its Allan curves (to "),
            std::string::npos)
      << report;
}

// One that pins a wander gives it to the norm fit as the unit's, as `standcal noise` would
// advise it (a 10x wander of 60 s over two hours: its curves turn over well inside them).
TEST(FitNoise, AStaticRecordingThatPinsAWanderGivesItToTheNormFit) {
  const RawInput raw = raw_input_of(bench_run_with_warm_up(0, 10, 60, 2));
  const NormCalibration norm = norm_fit_with_static(raw, bench_static_recording(2, 10, 60, 12));
  const NoiseFinding& n = norm.fit.result.noise;
  ASSERT_TRUE(norm.unit_static_recording);
  EXPECT_EQ(norm.unit_static_recording->gave, "wander") << norm.unit_static_recording->why;
  EXPECT_EQ(n.unit_wander_from, kWanderFromStaticRecording) << n.how;
  EXPECT_TRUE(n.unit_wander_given);
  EXPECT_NE(n.how.find("the ones its static recording's Allan curves pin"), std::string::npos)
      << n.how;
  // The correlation times weighted over are the ones the static recording's curves allow.
  ASSERT_GT(n.tau_given_max_s, n.tau_given_min_s) << n.how;
  char range[64];
  std::snprintf(range, sizeof range, "correlation time %.0f-%.0f s", n.tau_given_min_s,
                n.tau_given_max_s);
  EXPECT_NE(norm.unit_static_recording->why.find(range), std::string::npos)
      << range << " in " << norm.unit_static_recording->why;
  EXPECT_NE(
      format_norm_report(norm, raw).find("gave its wander: its Allan curves pin a wander of "),
      std::string::npos)
      << format_norm_report(norm, raw);
}

// What a static recording cannot give, it says why, and gives nothing: half an hour of a 10x
// wander of 300 s, whose curves see it but do not show it turn over; and beside a recording
// whose own warm-up pins a wander. A recording in other units than the calibration's is an
// error naming both, since its curves are put in ug by the calibration's scale.
TEST(FitNoise, AStaticRecordingSaysWhyItGaveTheNormFitNothing) {
  const RawInput raw = raw_input_of(bench_run_with_warm_up(0, 0, 300, 3));
  const NormCalibration norm = norm_fit_with_static(raw, bench_static_recording(0.5, 10, 300, 13));
  ASSERT_TRUE(norm.unit_static_recording);
  EXPECT_EQ(norm.unit_static_recording->gave, "nothing");
  EXPECT_NE(norm.unit_static_recording->why.find("see a wander they do not pin"), std::string::npos)
      << norm.unit_static_recording->why;
  EXPECT_FALSE(norm.fit.result.noise.sigmas_allowance_weighs_allan_curves);
  EXPECT_FALSE(norm.fit.result.noise.unit_wander_given);
  const std::string report = format_norm_report(norm, raw);
  EXPECT_NE(report.find("(0.5 h static) gave nothing: its Allan curves see a wander they do not "
                        "pin"),
            std::string::npos)
      << report;
  // The allowance stands, with no advice to give a static recording: one was given.
  EXPECT_NE(report.find("that these intervals cannot exclude\n"), std::string::npos) << report;

  // A static recording that shows no wander beside a recording whose own hour-long warm-up
  // pins one (10x, 60 s): the recording's own is weighted with, and the static one says so.
  const RawInput warmed = raw_input_of(bench_run_with_warm_up(3600, 10, 60, 23));
  const NormCalibration own = norm_fit_with_static(warmed, bench_static_recording(2, 0, 300, 15));
  ASSERT_TRUE(own.unit_static_recording);
  EXPECT_EQ(own.fit.result.noise.unit_wander_from, kWanderFromRecording)
      << own.fit.result.noise.how;
  EXPECT_EQ(own.unit_static_recording->gave, "nothing");
  EXPECT_NE(own.unit_static_recording->why.find(
                "show no wander; this recording's own long interval pins a wander, weighted with "
                "instead"),
            std::string::npos)
      << own.unit_static_recording->why;

  auto in_g = std::const_pointer_cast<RawInput>(bench_static_recording(2, 0, 300, 14));
  in_g->units = InputUnits::g;
  try {
    norm_fit_with_static(raw, in_g);
    ADD_FAILURE() << "a static recording in g beside one in m/s^2 was taken";
  } catch (const std::runtime_error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("unit-static.csv: the unit's static recording is in g and "),
              std::string::npos)
        << what;
    EXPECT_EQ(what.rfind("unit-static.csv: ", 0), 0u) << what;  // not prefixed by the run's
    EXPECT_NE(what.find("both must be in the same units"), std::string::npos) << what;
  }
}

// Over runs: white noise, no warm-up, and the two-hour static recording `standcal noise` then
// advises giving the fits (bench/noise --static-hours 2, its "unit given" rows). Without it
// the norm fit's biases were at 0.45-0.56 in z-variance over 1000 runs (docs/calibration.md,
// "The whole workflow"), their sigmas allowing for the wanders the intervals alone cannot
// exclude. These 100 seeds: 0.467 without the recording given, which fails, and 0.931 with it
// (sd about 0.09 at 1).
// The stand fits take its curves too (take_unit_wander_with_static_recording): the runs they weigh
// for a wander below the bar of a finding had their sigmas widened by Student-t at the few degrees
// of freedom the run leaves the wander's size, their biases at 0.14-0.24 in z-variance over 1000
// runs (full and joint; bench/noise --static-hours 2, 11819cf), where the curves now weigh
// the sizes. These seeds, over the runs so weighted: 0.145 (full, 24 runs) and 0.084 (joint,
// 16) before, which fail, and 1.139 and 0.901 since (sd about 0.2-0.3 at 1).
TEST(FitNoise, GivenAStaticRecordingEveryFitsSigmasAreWhiteNoisesUnderWhiteNoise) {
  STANDCAL_STATISTICAL_TEST();
  noise_mc::Setup setup = seeded_white_runs();
  setup.unit_given_rows = true;
  setup.static_hours = 2;
  const auto r = noise_mc::run_scenario(setup, {"white", 0, 300});
  expect_norm_biases_honest_under_white_noise(r, "unit given", "a 2 h static recording");
  expect_stand_runs_weighted_for_a_wander_honest(r, "unit given", "a 2 h static recording");
}

// The stand fits' order (take_unit_wander_with_static_recording): a pinned wander before either
// bound, the static recording's bound before the warm-up's, and no bound where a size of the
// unit's wander is given. White noise throughout: a one-hour warm-up whose curves show none,
// a two-hour static recording whose curves show none, and one of 72 s whose curves end before
// the fits' shortest correlation time (60 s).
TEST(FitNoise, TheStandFitsTakeTheBoundsInTheirOrder) {
  const Recording rec = bench_run_with_warm_up(3600, 0, 300, 31);
  const AveragedRecording averaged = average_recording(rec);
  ASSERT_TRUE(averaged.allan && averaged.allan->wander_curves) << "the warm-up's curves";
  const double g = rec.g_local_mps2;
  const UnitStaticAllan long_static =
      stand_unit_static_allan(*bench_static_recording(2, 0, 300, 32), g);
  const UnitStaticAllan short_static =
      stand_unit_static_allan(*bench_static_recording(0.02, 0, 300, 33), g);
  ASSERT_TRUE(long_static.allan.wander_curves);
  ASSERT_TRUE(short_static.allan.wander_curves);
  ASSERT_LT(short_static.allan.wander_curves->curves_end_s, 60);

  // The static recording's bound first, settled by the fit it bounded.
  FitNoiseOptions both;
  std::optional<UnitStaticRecordingUse> use =
      take_unit_wander_with_static_recording(both, rec, averaged.allan, &long_static);
  EXPECT_EQ(both.wander_curves_from, kWanderFromStaticRecording);
  EXPECT_TRUE(both.average_over_wander_sizes);
  const FitResult fit = fit_full_vector(averaged.averages, both);
  ASSERT_FALSE(fit.noise.bias_instability) << fit.noise.how;
  settle_unit_static_use(*use, fit.noise);
  EXPECT_EQ(use->gave, "bound") << use->why;
  EXPECT_EQ(fit.noise.sigmas_allowance_allan_curves_from, kWanderFromStaticRecording);

  // Curves too short to bound a wander of minutes: the warm-up's bound instead, and said so.
  FitNoiseOptions short_first;
  use = take_unit_wander_with_static_recording(short_first, rec, averaged.allan, &short_static);
  EXPECT_EQ(short_first.wander_curves_from, kWanderFromRecording);
  EXPECT_EQ(use->gave, "nothing");
  EXPECT_NE(use->why.find("end before the shortest correlation time the fits model (60 s): "
                          "record longer; this recording's own long dwell bounds the wander "
                          "instead"),
            std::string::npos)
      << use->why;

  // A size given: neither bounds it, and the static recording says why.
  FitNoiseOptions sized;
  sized.specified = {Vec3::Constant(3 * kUg), 300};
  use = take_unit_wander_with_static_recording(sized, rec, averaged.allan, &long_static);
  EXPECT_FALSE(sized.wander_curves_ug.has_value());
  EXPECT_FALSE(sized.average_over_wander_sizes);
  EXPECT_EQ(use->gave, "nothing");
  EXPECT_NE(use->why.find("was given"), std::string::npos) << use->why;
}

// standcald's runs carry their unit's static recording's curves in the header
// (unit.static_recording, kHeaderUnitStaticCurves) where those curves show no wander: every fit
// of the recording file then weighs them as `--unit-static-recording` would, to the bit, the
// stand fits and the norm fit alike. Until 2026-12-07 the runs carried only a wander the curves
// pin, so a static recording that showed none gave them nothing: the fits from the header
// were those without it (the third fit below), and the first checks failed.
TEST(FitNoise, TheStaticRecordingsCurvesARunsHeaderCarriesBoundItsFitsAsTheFileWould) {
  const test::TempDir dir;
  const std::shared_ptr<const RawInput> still = bench_static_recording(2, 0, 300, 11);
  Recording run = bench_run_with_warm_up(0, 0, 300, 1);
  const UnitStaticAllan still_allan = stand_unit_static_allan(*still, run.g_local_mps2);
  ASSERT_TRUE(still_allan.allan.wander_curves);
  run.set_header(kHeaderUnitStaticCurves, wander_curves_text(*still_allan.allan.wander_curves));
  run.set_header(kHeaderUnitWanderSource,
                 "the unit's static recording still.csv (2 h static) "
                 "gave its curves, to bound the wander");
  write_recording(run, dir.file("run.csv"));
  const Recording carried = read_recording(dir.file("run.csv"));
  Recording bare = carried;
  std::erase_if(bare.header, [](const auto& kv) { return kv.first == kHeaderUnitStaticCurves; });
  write_recording(bare, dir.file("bare.csv"));
  const AveragedRecording averaged = average_recording(carried);

  FitNoiseOptions given, from_header, neither;
  take_unit_wander_with_static_recording(given, bare, averaged.allan, &still_allan);
  take_unit_wander_with_static_recording(from_header, carried, averaged.allan, nullptr);
  take_unit_wander_with_static_recording(neither, bare, averaged.allan, nullptr);
  EXPECT_EQ(from_header.wander_curves_from, kWanderFromStaticRecording);
  const FitResult as_given = fit_full_vector(averaged.averages, given);
  const FitResult as_carried = fit_full_vector(averaged.averages, from_header);
  const FitResult without = fit_full_vector(averaged.averages, neither);
  ASSERT_FALSE(as_carried.noise.bias_instability) << as_carried.noise.how;
  EXPECT_EQ(as_carried.noise.sigmas_allowance_allan_curves_from, kWanderFromStaticRecording)
      << as_carried.noise.how;
  EXPECT_DOUBLE_EQ(as_carried.noise.sigmas_allow_wander_up_to_ug,
                   as_given.noise.sigmas_allow_wander_up_to_ug);
  for (std::size_t k = 0; k < kUnitParameterNames.size(); ++k)
    EXPECT_DOUBLE_EQ(*as_carried.unit[k].sigma, *as_given.unit[k].sigma) << kUnitParameterNames[k];
  // The curves are what made those sigmas: without them the biases' differ.
  EXPECT_NE(*as_carried.unit[0].sigma, *without.unit[0].sigma);
  // The command line's own static recording comes before the header's curves, and a size of
  // the unit's wander given leaves no room for either.
  const UnitStaticAllan other =
      stand_unit_static_allan(*bench_static_recording(2, 0, 300, 12), run.g_local_mps2);
  FitNoiseOptions both;
  take_unit_wander_with_static_recording(both, carried, averaged.allan, &other);
  ASSERT_TRUE(both.wander_curves_ug.has_value());
  EXPECT_EQ(both.wander_curves_ug->deviance(1, 300), other.allan.wander_curves->deviance(1, 300));
  EXPECT_NE(both.wander_curves_ug->deviance(1, 300),
            still_allan.allan.wander_curves->deviance(1, 300));
  FitNoiseOptions sized;
  sized.specified = {Vec3::Constant(3 * kUg), 300};
  take_unit_wander_with_static_recording(sized, carried, averaged.allan, nullptr);
  EXPECT_FALSE(sized.wander_curves_ug.has_value());

  // The norm fit, of the files as `standcal fit --method norm` reads them. Given the file, it
  // puts the static recording in ug by its own fitted scale factors, where the header's curves
  // are in ug by g as the stand fits put them: the sigmas agree to about 1e-6 here.
  const RawInput carried_input = read_input(dir.file("run.csv"));
  const NormCalibration norm_carried = norm_fit_of(carried_input);
  const NormCalibration norm_given = norm_fit_with_static(read_input(dir.file("bare.csv")), still);
  const NoiseFinding& n = norm_carried.fit.result.noise;
  EXPECT_EQ(n.sigmas_allowance_allan_curves_from, kWanderFromStaticRecording) << n.how;
  EXPECT_DOUBLE_EQ(n.sigmas_allow_wander_up_to_ug,
                   norm_given.fit.result.noise.sigmas_allow_wander_up_to_ug);
  for (std::size_t k = 0; k < kUnitParameterNames.size(); ++k) {
    const double given_sigma = *norm_given.fit.result.unit[k].sigma;
    EXPECT_NEAR(*norm_carried.fit.result.unit[k].sigma, given_sigma, 1e-5 * given_sigma)
        << kUnitParameterNames[k];
  }
  // Its report says what standcald's static recording gave the run, as the stand report does,
  // and advises no static recording it already has.
  const std::string report = format_norm_report(norm_carried, carried_input);
  EXPECT_NE(report.find("that these intervals and the unit's static recording cannot exclude\n"
                        "            its run, by standcald's unit.static_recording: the unit's "
                        "static recording still.csv"),
            std::string::npos)
      << report;
  EXPECT_EQ(report.find("--unit-static-recording"), std::string::npos) << report;
}

// The curves as the header carries them: their text gives back the same likelihood of every
// wander, and the recording reader refuses a value that is not such curves at its line, naming
// the key and what is wrong in it, whatever the fit would weigh.
TEST(FitNoise, TheCarriedCurvesRoundTripAndABadOneIsRefusedAtItsLine) {
  const UnitStaticAllan still =
      stand_unit_static_allan(*bench_static_recording(2, 0, 300, 11), kStandardGravity_mps2);
  ASSERT_TRUE(still.allan.wander_curves);
  const WanderCurves& curves = *still.allan.wander_curves;
  const std::string text = wander_curves_text(curves);
  const WanderCurves back = parse_wander_curves(text);
  EXPECT_EQ(back.curves_end_s, curves.curves_end_s);
  for (const double q_ug : {0.0, 0.5, 3.0})
    for (const double tau_s : {60.0, 300.0, 1200.0})
      EXPECT_EQ(back.deviance(q_ug, tau_s), curves.deviance(q_ug, tau_s)) << q_ug << ", " << tau_s;

  const test::TempDir dir;
  Recording run = bench_run_with_warm_up(0, 0, 300, 1);
  const auto read_error = [&](const std::string& value) {
    run.set_header(kHeaderUnitStaticCurves, value);
    write_recording(run, dir.file("run.csv"));
    try {
      read_recording(dir.file("run.csv"));
    } catch (const RecordingError& e) {
      return std::string(e.what());
    }
    return std::string("read");
  };
  EXPECT_EQ(read_error(text), "read");
  // The key's line in the file as written.
  const auto key_line = [&] {
    std::ifstream in(dir.file("run.csv"));
    std::string line;
    for (int n = 1; std::getline(in, line); ++n)
      if (line.rfind("# unit_static_allan_curves:", 0) == 0) return n;
    return 0;
  };
  const auto expect_refused = [&](const std::string& value, const std::string& why) {
    const std::string error = read_error(value);
    EXPECT_NE(error.find(dir.file("run.csv") + ":" + std::to_string(key_line()) + ":"),
              std::string::npos)
        << error;
    EXPECT_NE(error.find(": header 'unit_static_allan_curves': not the Allan curves of a static "
                         "recording: " +
                         why),
              std::string::npos)
        << error;
  };
  expect_refused("{\"curves_end_s\": 7200", "not JSON");
  expect_refused("{}", "curves_end_s is not a number");
  const auto edited = [&](const std::function<void(nlohmann::json&)>& edit) {
    nlohmann::json j = nlohmann::json::parse(text);
    edit(j);
    return j.dump();
  };
  expect_refused(edited([](nlohmann::json& j) { j["axes"].erase(2); }),
                 "'axes' needs three curves, x, y and z");
  expect_refused(edited([](nlohmann::json& j) { j["axes"][1]["deviation"][1] = -1; }),
                 "axis y point 2 deviation (ug) is -1, not above 0");
  expect_refused(edited([](nlohmann::json& j) { j["axes"][1]["deviation"][1] = 1e-200; }),
                 "axis y point 2 deviation (ug) is 1e-200, outside 1e-06 ... 1000000");
  // Beside the other points' few ug, 7e105 ug made the deviance's sums overflow: not a number
  // (fuzz/regressions/wander_curves).
  expect_refused(edited([](nlohmann::json& j) { j["axes"][1]["deviation"][7] = 6.7e105; }),
                 "axis y point 8 deviation (ug) is 6.7e+105, outside 1e-06 ... 1000000");
  expect_refused(edited([](nlohmann::json& j) { j["axes"][0]["clusters"][0] = 0.5; }),
                 "axis x point 1 clusters is 0.5, outside 1 ... 1000000000000");
  expect_refused(edited([](nlohmann::json& j) { j["axes"][0]["tau_s"][0] = 1e-7; }),
                 "axis x point 1 tau_s is 1e-07, outside 1e-06 ... 1000000000000");
  expect_refused(edited([](nlohmann::json& j) { j["axes"][0]["tau_s"][1] = "long"; }),
                 "axis x point 2 tau_s is not a number");
  expect_refused(
      edited([](nlohmann::json& j) { j["axes"][0]["tau_s"][1] = j["axes"][0]["tau_s"][0]; }),
      "axis x point 2 tau_s does not rise from the point before");
  expect_refused(edited([](nlohmann::json& j) { j["axes"][2] = 3; }),
                 "axis z is not a JSON object");
  expect_refused(edited([](nlohmann::json& j) { j["axes"][2]["clusters"].erase(0); }),
                 "axis z: 'tau_s', 'deviation' and 'clusters' need one value per point, and at "
                 "least 5 points");
  expect_refused(edited([](nlohmann::json& j) { j["curves_end_s"] = 10; }),
                 "curves_end_s 10 s is before axis x's last point");
  expect_refused(edited([](nlohmann::json& j) { j["deviance_scale"] = 1e300; }),
                 "deviance_scale is 1e+300, above ");

  // A recording made in memory reaches the fits unread: they refuse it, naming it.
  Recording in_memory;
  in_memory.source = "run.csv";
  in_memory.set_header(kHeaderUnitStaticCurves, "{}");
  FitNoiseOptions options;
  try {
    take_header_static_curves(options, in_memory);
    ADD_FAILURE() << "taken";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()),
              "run.csv: header 'unit_static_allan_curves': not the Allan curves of a static "
              "recording: curves_end_s is not a number");
  }
}

namespace {

// The Allan curves of a seeded two-hour static recording of the default unit (10 Hz) whose
// axes wander each its own (q_ug, correlation time tau_s), as a stand fit takes them; axis a
// drawn from seed first_seed + a.
UnitStaticAllan two_hour_static_allan_of_axes(const Vec3& q_ug, double tau_s, unsigned first_seed) {
  const TruthModel truth = default_truth();
  std::vector<std::vector<double>> axes;
  for (int a = 0; a < 3; ++a)
    axes.push_back(simulate_static_gauss_markov(
        truth.noise.density_ug_rthz, q_ug[a], tau_s, 2 * 3600, noise_mc::kStaticRecordingRateHz,
        first_seed + static_cast<unsigned>(a))[static_cast<std::size_t>(a)]);
  return stand_unit_static_allan(
      *noise_mc::static_raw_input(axes, noise_mc::kStaticRecordingRateHz, truth.g_local_mps2),
      truth.g_local_mps2);
}

// A seeded run without a warm-up (tau 60 s) whose stand fits are given `unit_static`.
struct RunGivenAStaticRecording {
  AveragedRecording averaged;
  FitNoiseOptions noise;
  std::optional<UnitStaticRecordingUse> use;
};
RunGivenAStaticRecording run_given(const UnitStaticAllan& unit_static, std::uint64_t seed) {
  const Recording rec = bench_run_with_warm_up(0, 0, 60, seed);
  RunGivenAStaticRecording r{average_recording(rec), {}, {}};
  r.use = take_unit_wander_with_static_recording(r.noise, rec, r.averaged.allan, &unit_static);
  return r;
}

// A run whose warm-up puts a floor under the correlation time, given beside it a two-hour
// static recording whose curves show no wander: what the static recording's words say once the
// full-vector fit (`fit`) has settled them.
UnitStaticRecordingUse static_recording_words_beside_a_floor(const Recording& rec,
                                                             const AveragedRecording& averaged,
                                                             FitResult& fit) {
  const UnitStaticAllan still =
      stand_unit_static_allan(*bench_static_recording(2, 0, 300, 32), rec.g_local_mps2);
  FitNoiseOptions noise;
  std::optional<UnitStaticRecordingUse> use =
      take_unit_wander_with_static_recording(noise, rec, averaged.allan, &still);
  EXPECT_TRUE(noise.known_tau && noise.known_tau->open_above) << "the warm-up's floor";
  if (!use) return {};
  fit = fit_full_vector(averaged.averages, noise);
  settle_unit_static_use(*use, fit.noise);
  return *use;
}

constexpr const char* kRecordingTauFloorWords =
    "; this recording's own long dwell sees a wander it does not pin, whose correlation time it "
    "bounds from below";

}  // namespace

// A unit whose axes wander unalike (3, 6 and 12 ug, 60 s): the static recording's curves give
// each axis its own size, which the fits weigh with, and its words and JSON say them. Until
// 2026-12-07 the largest axis's was given to every axis: x's wander taken as 16 times its
// variance (the first check fails so), and over 1000 runs of bench/noise (--static-hours 2)
// the biases' z-variance at 1x was 0.84-0.86 where the axes wander alike.
TEST(FitNoise, AStaticRecordingGivesEachAxisItsOwnWander) {
  const Vec3 q_ug(3, 6, 12);
  const UnitStaticAllan unit_static = two_hour_static_allan_of_axes(q_ug, 60, 40);
  const auto [averaged, noise, use] = run_given(unit_static, 41);
  ASSERT_TRUE(use.has_value());
  ASSERT_EQ(use->gave, "wander") << use->why;
  const Vec3 q = use->wander.axes_ug();
  for (int a = 0; a < 3; ++a) EXPECT_NEAR(q[a] / q_ug[a], 1, 0.4) << "axis " << a << ": " << q;
  EXPECT_DOUBLE_EQ(use->wander.size_ug, q.maxCoeff());
  const FitResult fit = fit_full_vector(averaged.averages, noise);
  EXPECT_EQ(fit.noise.unit_wander_from, kWanderFromStaticRecording) << fit.noise.how;
  for (int a = 0; a < 3; ++a) EXPECT_DOUBLE_EQ(fit.noise.wander_ug[a], q[a]) << fit.noise.how;
  char words[96];
  std::snprintf(words, sizeof words,
                "its Allan curves pin a wander of %.3g / %.3g / %.3g ug (x/y/z)", q[0], q[1], q[2]);
  EXPECT_EQ(use->why.rfind(words, 0), 0u) << use->why;
  const nlohmann::json j = unit_static_recording_json(*use);
  EXPECT_EQ(j["wander_ug"], nlohmann::json::array({q[0], q[1], q[2]})) << j;
}

// A warm-up of six correlation times (two hours of a 1200 s wander, 3x the dwell error) sees
// the wander but ends before it turns over: its curves pin none, but put a floor under its
// correlation time, at which and up to the fits' longest the fits weigh the run's own wander.
// One run's rows allow the short times too, at which the biases' sigmas come out several
// times too small (docs/calibration.md, "Curves that see a wander they do not pin"). Until
// 2026-12-07 the warm-up gave the fits nothing here (take_recording_wander_or_bound false).
TEST(FitNoise, AWarmUpThatSeesAWanderItDoesNotPinPutsAFloorUnderItsCorrelationTime) {
  const Recording rec = bench_run_with_warm_up(7200, 3, 1200, kUnpinnedWarmUpSeed);
  const AveragedRecording averaged = average_recording(rec);
  ASSERT_TRUE(averaged.allan.has_value());
  ASSERT_FALSE(averaged.allan->wander.has_value()) << "the case this test is of: it pins none";
  const double floor_s = averaged.allan->wander_tau_floor_s;
  ASSERT_GT(floor_s, 60) << "the case this test is of: a floor above the fits' shortest";
  EXPECT_LT(floor_s, 1200) << "the simulated wander's is within what the curves allow";

  FitNoiseOptions noise;
  ASSERT_TRUE(take_recording_wander_or_bound(noise, averaged.allan));
  ASSERT_TRUE(noise.known_tau.has_value());
  EXPECT_EQ(noise.known_tau->min_s, floor_s);
  EXPECT_EQ(noise.known_tau->max_s, 1200);
  EXPECT_TRUE(noise.known_tau->open_above);
  EXPECT_TRUE(noise.specified.white()) << "its size is the run's own";
  FitNoiseOptions diagnosis;  // the diagnosis's rule takes the same
  ASSERT_TRUE(take_unit_wander(diagnosis, rec, averaged.allan, std::nullopt));
  EXPECT_EQ(diagnosis.known_tau->min_s, floor_s);

  const FitResult floored = fit_full_vector(averaged.averages, noise);
  const FitResult unfloored = fit_full_vector(averaged.averages, FitNoiseOptions{});
  ASSERT_TRUE(floored.noise.bias_instability) << floored.noise.how;
  ASSERT_LT(unfloored.noise.tau_s, floor_s) << "the case this test is of: " << unfloored.noise.how;
  EXPECT_TRUE(floored.noise.tau_given_open_above);
  EXPECT_GE(floored.noise.tau_s, floor_s) << floored.noise.how;
  EXPECT_GE(floored.noise.tau_plausible_min_s, floor_s) << floored.noise.how;
  for (int a = 0; a < 3; ++a) {
    const auto bias = static_cast<std::size_t>(a);
    EXPECT_GT(*floored.unit[bias].sigma, *unfloored.unit[bias].sigma) << "bias " << a;
  }
  const nlohmann::json j = fit_to_json(floored)["noise"];
  EXPECT_EQ(j["tau_given_open_above"], true) << j;
  EXPECT_EQ(j["tau_given_s"], nlohmann::json::array({floor_s, 1200.0})) << j;
  const std::string report = format_report(floored, report_context(rec, averaged.averages));
  char words[160];
  std::snprintf(words, sizeof words,
                "a long static stretch's Allan curves see a wander they do not pin, and put its "
                "correlation time at %.0f s or longer",
                floor_s);
  EXPECT_NE(report.find(words), std::string::npos) << report;

  // Beside the unit's static recording, its words say the floor, and that the fit kept it.
  FitResult beside;
  const UnitStaticRecordingUse use = static_recording_words_beside_a_floor(rec, averaged, beside);
  EXPECT_TRUE(beside.noise.tau_given_open_above) << beside.noise.how;
  EXPECT_NE(use.why.find(kRecordingTauFloorWords), std::string::npos) << use.why;
  EXPECT_EQ(use.why.find("set aside"), std::string::npos) << use.why;
}

// The unit's static recording of two hours likewise sees a slow wander (10x the dwell error,
// 1200 s) it does not pin, and puts a floor under its correlation time: the stand fits and the
// norm fit take it as they take a warm-up's, the higher of the two where both put one, and its
// words and JSON say whether the fit kept it ("floor") or set it aside ("nothing", where the
// run's rows do not show the wander at those times: here a run of white noise). Until
// 2026-12-07 such a static recording gave the fits nothing: the first checks failed.
TEST(FitNoise, AStaticRecordingThatSeesAWanderItDoesNotPinPutsAFloorUnderItsCorrelationTime) {
  const std::shared_ptr<const RawInput> slow_rows =
      bench_static_recording(2, 10, 1200, kSlowStaticRecordingSeed);
  const Recording rec = bench_run_with_warm_up(0, 10, 1200, kSlowRunSeed);
  const AveragedRecording averaged = average_recording(rec);
  const UnitStaticAllan slow = stand_unit_static_allan(*slow_rows, rec.g_local_mps2);
  ASSERT_FALSE(slow.allan.wander.has_value()) << "the case this test is of: it pins none";
  const double floor_s = slow.allan.wander_tau_floor_s;
  ASSERT_GT(floor_s, 60) << "the case this test is of: a floor above the fits' shortest";

  FitNoiseOptions noise;
  std::optional<UnitStaticRecordingUse> use =
      take_unit_wander_with_static_recording(noise, rec, averaged.allan, &slow);
  ASSERT_TRUE(noise.known_tau && noise.known_tau->open_above);
  EXPECT_EQ(noise.known_tau->min_s, floor_s);
  EXPECT_EQ(noise.specified_from, kWanderFromStaticRecording);
  const FitResult floored = fit_full_vector(averaged.averages, noise);
  const FitResult unfloored = fit_full_vector(averaged.averages, FitNoiseOptions{});
  ASSERT_TRUE(floored.noise.tau_given_open_above) << floored.noise.how;
  ASSERT_LT(unfloored.noise.tau_s, floor_s) << "the case this test is of: " << unfloored.noise.how;
  for (std::size_t bias = 0; bias < 3; ++bias)
    EXPECT_GT(*floored.unit[bias].sigma, *unfloored.unit[bias].sigma) << "bias " << bias;
  settle_unit_static_use(*use, floored.noise);
  EXPECT_EQ(use->gave, "floor") << use->why;
  char words[160];
  std::snprintf(words, sizeof words,
                "do not show it turn over: record about 100 x its correlation time): they put its "
                "correlation time at %.0f s or longer, which the sigmas allow for",
                floor_s);
  EXPECT_NE(use->why.find(words), std::string::npos) << use->why;
  EXPECT_EQ(unit_static_recording_json(*use)["tau_floor_s"], floor_s);
  EXPECT_NE(unit_static_recording_words(*use).find(
                "gave a floor under the wander's correlation time: its Allan curves see a wander"),
            std::string::npos)
      << unit_static_recording_words(*use);

  // A standcald run's header carries the floor (kHeaderUnitStaticTauFloorS): a fit of the run
  // given no static recording takes it as the file's own, to the bit.
  const test::TempDir dir;
  Recording carrying = rec;
  carrying.set_header(kHeaderUnitStaticTauFloorS, round_trip_text(floor_s));
  write_recording(carrying, dir.file("run.csv"));
  const Recording carried = read_recording(dir.file("run.csv"));
  EXPECT_EQ(carried.unit_static_tau_floor_s, floor_s);
  FitNoiseOptions from_header;
  take_unit_wander_with_static_recording(from_header, carried, averaged.allan, nullptr);
  ASSERT_TRUE(from_header.known_tau && from_header.known_tau->open_above);
  EXPECT_EQ(from_header.known_tau->min_s, floor_s);
  EXPECT_EQ(from_header.specified_from, kWanderFromStaticRecording);
  const FitResult as_carried = fit_full_vector(averaged.averages, from_header);
  for (std::size_t k = 0; k < kUnitParameterNames.size(); ++k)
    EXPECT_DOUBLE_EQ(*as_carried.unit[k].sigma, *floored.unit[k].sigma) << kUnitParameterNames[k];

  // The norm fit of the same run takes it too, from the file and from the header.
  const NormCalibration norm = norm_fit_with_static(raw_input_of(rec), slow_rows);
  ASSERT_TRUE(norm.unit_static_recording);
  EXPECT_TRUE(norm.fit.result.noise.tau_given_open_above) << norm.fit.result.noise.how;
  EXPECT_EQ(norm.unit_static_recording->gave, "floor") << norm.unit_static_recording->why;
  char floor_words[64];
  std::snprintf(floor_words, sizeof floor_words,
                "they put its correlation time at %.0f s or longer", floor_s);
  EXPECT_NE(norm.unit_static_recording->why.find(floor_words), std::string::npos)
      << norm.unit_static_recording->why;
  const NormCalibration norm_carried = norm_fit_of(read_input(dir.file("run.csv")));
  EXPECT_TRUE(norm_carried.fit.result.noise.tau_given_open_above)
      << norm_carried.fit.result.noise.how;
  EXPECT_EQ(norm_carried.fit.result.noise.tau_given_min_s, floor_s);

  // A run of white noise: set aside, and said so.
  const Recording white = bench_run_with_warm_up(0, 0, 1200, kSlowRunSeed);
  const AveragedRecording white_averaged = average_recording(white);
  FitNoiseOptions white_noise;
  use = take_unit_wander_with_static_recording(white_noise, white, white_averaged.allan, &slow);
  const FitResult white_fit = fit_full_vector(white_averaged.averages, white_noise);
  EXPECT_FALSE(white_fit.noise.tau_given_open_above) << white_fit.noise.how;
  settle_unit_static_use(*use, white_fit.noise);
  EXPECT_EQ(use->gave, "nothing");
  EXPECT_NE(use->why.find("or longer, a floor this fit set aside: this run's dwells do not show "
                          "the wander at those times"),
            std::string::npos)
      << use->why;

  // Beside it the bound of the recording's own warm-up, whose curves show no wander, as the
  // norm fit takes both: the fit that sets the floor aside is bounded by the warm-up.
  const Recording warmed = bench_run_with_warm_up(3600, 0, 1200, kSlowRunSeed);
  const AveragedRecording warmed_averaged = average_recording(warmed);
  ASSERT_TRUE(warmed_averaged.allan && warmed_averaged.allan->wander_curves);
  FitNoiseOptions beside;
  take_unit_wander_with_static_recording(beside, warmed, warmed_averaged.allan, &slow);
  EXPECT_TRUE(beside.known_tau && beside.known_tau->open_above);
  EXPECT_EQ(beside.wander_curves_from, kWanderFromRecording);
  ASSERT_TRUE(beside.wander_curves_ug.has_value());
  const FitResult bounded = fit_full_vector(warmed_averaged.averages, beside);
  EXPECT_FALSE(bounded.noise.tau_given_open_above) << bounded.noise.how;
  EXPECT_EQ(bounded.noise.sigmas_allowance_allan_curves_from, kWanderFromRecording)
      << bounded.noise.how;
}

// Two hours of a 1200 s wander (10x the dwell error) whose curves, ending at 1995 s, bound its
// correlation time but do not show the slowest of it turn over (its Allan peak near 1.89 x it):
// seed 1 allows 343-1358 s, seed 4 432-2410 s. Until 2026-12-07 the first was weighted with as a
// pinned wander, at the size the curves give at the range's middle, and the second gave the fits
// nothing (no floor: its range was not open above); on the bench's runs given such recordings
// the biases' z-variance was 2.4-3.8 (docs/calibration.md, "A range that ends beyond the
// curves"). Both now put a floor at the range's shortest time, as curves open above do.
TEST(FitNoise, CurvesThatEndBeforeTheSlowestWanderTheyAllowTurnsOverPutAFloorUnderIt) {
  const Recording rec = bench_run_with_warm_up(0, 10, 1200, kSlowRunSeed);
  const AveragedRecording averaged = average_recording(rec);
  for (const unsigned seed : {1U, 4U}) {
    SCOPED_TRACE("static recording seed " + std::to_string(seed));
    const UnitStaticAllan slow =
        stand_unit_static_allan(*bench_static_recording(2, 10, 1200, seed), rec.g_local_mps2);
    ASSERT_TRUE(slow.allan.wander.has_value()) << "the case this test is of: a range they bound";
    const WanderToGive& w = *slow.allan.wander;
    ASSERT_FALSE(curves_show_turnover(w.tau_max_s, w.curves_end_s))
        << w.tau_min_s << "-" << w.tau_max_s << " s, curves to " << w.curves_end_s << " s";
    EXPECT_EQ(slow.allan.wander_tau_floor_s, w.tau_min_s);

    FitNoiseOptions noise;
    std::optional<UnitStaticRecordingUse> use =
        take_unit_wander_with_static_recording(noise, rec, averaged.allan, &slow);
    EXPECT_TRUE(noise.specified.white()) << "no wander pinned: its size is the run's own";
    ASSERT_TRUE(noise.known_tau && noise.known_tau->open_above);
    EXPECT_EQ(noise.known_tau->min_s, w.tau_min_s);
    EXPECT_EQ(noise.known_tau->max_s, 1200);
    const FitResult fit = fit_full_vector(averaged.averages, noise);
    EXPECT_TRUE(fit.noise.tau_given_open_above) << fit.noise.how;
    settle_unit_static_use(*use, fit.noise);
    EXPECT_EQ(use->gave, "floor") << use->why;
    char words[240];
    std::snprintf(words, sizeof words,
                  "its Allan curves see a wander they do not pin (correlation time %.0f-%.0f s, "
                  "but they end at %.0f s, before the slowest of those turns over",
                  w.tau_min_s, w.tau_max_s, w.curves_end_s);
    EXPECT_NE(use->why.find(words), std::string::npos) << use->why;
    std::snprintf(words, sizeof words, "they put its correlation time at %.0f s or longer",
                  w.tau_min_s);
    EXPECT_NE(use->why.find(words), std::string::npos) << use->why;
  }
}

// The norm fit given a correlation time beside the unit's static recording keeps it: the floor
// the recording's curves put is not taken, and its words say so, as they do of curves that
// bound a wander's times without showing the slowest turn over (static seed 1). Neither branch
// of these words was tested before.
TEST(FitNoise, TheNormFitSaysAGivenCorrelationTimeOutranksTheStaticRecordingsFloor) {
  const Recording rec = bench_run_with_warm_up(0, 10, 1200, kSlowRunSeed);
  for (const unsigned seed : {kSlowStaticRecordingSeed, 1U}) {
    SCOPED_TRACE("static recording seed " + std::to_string(seed));
    NormCalibrationOptions options;
    options.stability = false;
    options.unit_static_recording = bench_static_recording(2, 10, 1200, seed);
    options.fit.noise.known_tau = KnownTau{600, 600};
    const NormCalibration norm = calibrate_without_angles(raw_input_of(rec), options);
    ASSERT_TRUE(norm.unit_static_recording);
    EXPECT_FALSE(norm.fit.result.noise.tau_given_open_above) << norm.fit.result.noise.how;
    EXPECT_EQ(norm.fit.result.noise.tau_s, 600) << norm.fit.result.noise.how;
    const std::string& why = norm.unit_static_recording->why;
    EXPECT_NE(why.find(", but a correlation time was given, which it does not override"),
              std::string::npos)
        << why;
    if (seed == 1U)
      EXPECT_NE(why.find("before the slowest of those turns over"), std::string::npos) << why;
    // Either way the floor the curves put is named, as not taken (for seed 1, a range short of
    // the turnover, not named until 2026-12-07).
    std::smatch floor;
    ASSERT_TRUE(std::regex_search(why, floor,
                                  std::regex(": they put its correlation time at ([0-9]+) s or "
                                             "longer, but a correlation time was given")))
        << why;
    EXPECT_GT(std::stod(floor[1]), 60) << "above the fits' shortest";
  }
}

// Above a floor the curves cannot tell the correlation times apart, and one run's rows favour
// the short end, where a bias's variance is smallest: the biases' sigmas are the widest over the
// range, as large as the fit's given its longest time alone, where the rows' likelihood had
// weighted them towards the floor's (the floor's run above, and a warm-up's: bench/noise --tau-s
// 1200 --static-hours 2, 10x, the biases at 1.75-2.08 in z-variance before, docs/calibration.md).
TEST(FitNoise, AFloorWeighsTheBiasesAtTheSlowestTimeItAllows) {
  const Recording warmed = bench_run_with_warm_up(7200, 3, 1200, kUnpinnedWarmUpSeed);
  const Recording slow = bench_run_with_warm_up(0, 10, 1200, kSlowRunSeed);
  for (const Recording* rec : {&warmed, &slow}) {
    const AveragedRecording averaged = average_recording(*rec);
    ASSERT_TRUE(averaged.allan.has_value());
    const double floor_s = rec == &warmed ? averaged.allan->wander_tau_floor_s : 859.0;
    SCOPED_TRACE("floor " + std::to_string(floor_s));
    FitNoiseOptions floored, at_longest;
    ASSERT_TRUE(take_tau_floor(floored, floor_s, kWanderFromRecording));
    at_longest.known_tau = KnownTau{1200, 1200};
    const FitResult fit = fit_full_vector(averaged.averages, floored);
    const FitResult longest = fit_full_vector(averaged.averages, at_longest);
    ASSERT_TRUE(fit.noise.tau_given_open_above && fit.noise.bias_instability) << fit.noise.how;
    EXPECT_EQ(fit.noise.tau_plausible_min_s, floor_s) << "every time of the range is kept";
    EXPECT_EQ(fit.noise.tau_plausible_max_s, 1200) << "every time of the range is kept";
    for (std::size_t bias = 0; bias < 3; ++bias)
      EXPECT_GE(*fit.unit[bias].sigma, 0.97 * *longest.unit[bias].sigma) << "bias " << bias;
  }
}

// Curves a run's header cannot hold (a deviation below what the readers take, 1e-6 ug) are given
// to no run, and said: until 2026-12-07 standcald wrote them into every run's header, which every
// reader then refused (the first check failed).
TEST(FitNoise, StaticCurvesARunsHeaderCannotHoldAreGivenToNoRun) {
  UnitStaticAllan unit_static;
  unit_static.use.why = "its Allan curves (to 2000 s) show no wander";
  WanderCurves curves;
  curves.curves_end_s = 2000;
  curves.deviance_scale = kWanderCurvesDevianceScale;
  for (int a = 0; a < 3; ++a) {
    ThinnedAllanCurve c;
    for (double tau_s : {1.0, 10.0, 100.0, 1000.0, 2000.0}) {
      AllanPoint p;
      p.tau_s = tau_s;
      p.deviation = 3 / std::sqrt(tau_s);  // white noise, ug
      c.points.push_back(p);
      c.clusters.push_back(7200 / tau_s);
    }
    curves.axes.push_back(c);
  }
  curves.axes[0].points[0].deviation = 1e-8;  // an axis all but stuck, at rounding level
  unit_static.allan.wander_curves = curves;
  FitNoiseOptions options;
  const UnitStaticRecordingUse use = take_static_recording_for_runs(options, unit_static);
  EXPECT_EQ(use.gave, "nothing") << use.why;
  EXPECT_FALSE(options.wander_curves_ug.has_value());
  EXPECT_FALSE(options.average_over_wander_sizes);
  EXPECT_NE(use.why.find("; its curves lie beyond what a run's header holds (axis x point 1 "
                         "deviation (ug) is 1e-08, outside 1e-06 ... 1000000), so the runs are "
                         "given none"),
            std::string::npos)
      << use.why;
  // Curves the header cannot hold beside a floor under the correlation time: the floor is still
  // given (the first draft of the check gave nothing).
  unit_static.allan.wander_tau_floor_s = 500;
  FitNoiseOptions floored;
  const UnitStaticRecordingUse floor_use = take_static_recording_for_runs(floored, unit_static);
  EXPECT_EQ(floor_use.gave, "floor") << floor_use.why;
  EXPECT_EQ(floor_use.tau_floor_s, 500);
  EXPECT_FALSE(floored.wander_curves_ug.has_value());
  unit_static.allan.wander_tau_floor_s = 0;
  curves.axes[0].points[0].deviation = 3;  // within: carried
  unit_static.allan.wander_curves = curves;
  FitNoiseOptions carried;
  EXPECT_EQ(take_static_recording_for_runs(carried, unit_static).gave, "curves");
}

// A floor at or beyond the longest correlation time the fits model (1200 s) is the one time the
// sigmas weigh (KnownTau{floor, floor}): the words say so, not "up to the longest the fits
// model", which they said until 2026-12-07 (the second check failed).
TEST(FitNoise, AStaticFloorBeyondTheLongestModelledIsSaidToBeTheOneTimeWeighed) {
  NoiseFinding within;
  within.tau_given_open_above = true;
  within.tau_given_min_s = 800;
  within.tau_given_max_s = 1200;
  UnitStaticRecordingUse use;
  use.gave = "floor";
  use.tau_floor_s = 800;
  settle_unit_static_use(use, within);
  EXPECT_EQ(use.gave, "floor");
  EXPECT_NE(use.why.find("at 800 s or longer, which the sigmas allow for up to the longest the "
                         "fits model"),
            std::string::npos)
      << use.why;
  NoiseFinding beyond;
  beyond.tau_given_open_above = true;
  beyond.tau_s = 1500;  // KnownTau{1500, 1500}: no range
  UnitStaticRecordingUse slow;
  slow.gave = "floor";
  slow.tau_floor_s = 1500;
  settle_unit_static_use(slow, beyond);
  EXPECT_EQ(slow.gave, "floor");
  EXPECT_NE(slow.why.find("at 1500 s or longer, which the sigmas weigh as its correlation time (at "
                          "or beyond the longest the fits model)"),
            std::string::npos)
      << slow.why;
}

// Where the recording's own long dwell puts the higher floor under the correlation time, the
// static recording's lower one is said to be passed over for it; until 2026-12-07 its words said
// nothing of its floor (the last check failed).
TEST(FitNoise, AStaticFloorBelowTheRecordingsOwnIsSaidToBePassedOver) {
  UnitStaticAllan unit_static;
  unit_static.allan.wander_tau_floor_s = 300;
  unit_static.use.why = "its Allan curves see a wander they do not pin";
  AllanFinding own;
  own.wander_tau_floor_s = 600;
  FitNoiseOptions options;
  const std::optional<UnitStaticRecordingUse> use =
      take_unit_wander_with_static_recording(options, Recording{}, own, &unit_static);
  ASSERT_TRUE(use.has_value());
  ASSERT_TRUE(options.known_tau.has_value());
  EXPECT_EQ(options.known_tau->min_s, 600);
  EXPECT_EQ(options.specified_from, kWanderFromRecording);
  EXPECT_NE(use->why.find("they put its correlation time at 300 s or longer, not above the floor "
                          "this recording's own long dwell puts, taken instead"),
            std::string::npos)
      << use->why;
}

// The diagnosis weighs the unit's static recording's floor under the correlation time as the fits
// do (take_unit_wander): given (`diagnose --unit-static-recording`) or carried in a standcald
// run's header, it tests the terms under it where the revisits show the wander at those times,
// and sets it aside where they do not (a run of white noise); its words say which. Until
// 2026-12-07 it took only the recording's own floor, so a recording's fit and its diagnosis
// weighed different correlation times: the first checks failed.
TEST(FitNoise, TheDiagnosisWeighsTheStaticRecordingsFloorAsTheFitsDo) {
  const std::shared_ptr<const RawInput> slow_rows =
      bench_static_recording(2, 10, 1200, kSlowStaticRecordingSeed);
  const Recording rec = bench_run_with_warm_up(0, 10, 1200, kSlowRunSeed);
  const UnitStaticAllan slow = stand_unit_static_allan(*slow_rows, rec.g_local_mps2);
  const double floor_s = slow.allan.wander_tau_floor_s;
  ASSERT_GT(floor_s, 60) << "the case this test is of: a floor above the fits' shortest";
  DiagnoseOptions given;
  given.unit_static_tau_floor_s = floor_s;
  // The simulated wander (10x a dwell's 3.2 ug) is beyond a navigation-grade unit's class bound,
  // which would refuse it as noise: this unit's class is coarser.
  given.max_bias_instability_ug = 100;
  const Diagnosis d = diagnose_recording(rec, given);
  EXPECT_EQ(d.tau_floor_from, kWanderFromStaticRecording);
  EXPECT_EQ(d.tau_floor_outcome, "kept");
  ASSERT_TRUE(d.noise.tau_given_open_above) << d.noise.how;
  EXPECT_EQ(d.noise.tau_given_min_s, floor_s) << d.noise.how;
  EXPECT_GE(d.noise.tau_s, floor_s) << d.noise.how;
  DiagnoseOptions no_floor = given;
  no_floor.unit_static_tau_floor_s.reset();
  const Diagnosis without = diagnose_recording(rec, no_floor);
  EXPECT_TRUE(without.tau_floor_from.empty()) << without.tau_floor_from;
  EXPECT_LT(without.noise.tau_s, floor_s) << "the case this test is of: " << without.noise.how;
  // What the static recording's words say of the floor after a diagnosis (the CLI's).
  const auto said_after = [&](const Diagnosis& diagnosis) {
    UnitStaticRecordingUse use = slow.use;
    use.tau_floor_s = floor_s;
    say_diagnosis_static_tau_floor(use, diagnosis.tau_floor_from, diagnosis.tau_floor_outcome,
                                   diagnosis.noise, false);
    return use;
  };
  const UnitStaticRecordingUse use = said_after(d);
  EXPECT_EQ(use.gave, "floor") << use.why;
  char words[160];
  std::snprintf(words, sizeof words,
                "they put its correlation time at %.0f s or longer, under which the diagnosis "
                "estimates the wander the terms are tested against",
                floor_s);
  EXPECT_NE(use.why.find(words), std::string::npos) << use.why;
  // A navigation-grade class bound (6 ug) refuses that wander as noise after it was estimated
  // under the floor: kept, and the noise's words say it was refused, not that it was not shown.
  DiagnoseOptions navigation_grade = given;
  navigation_grade.max_bias_instability_ug = DiagnoseOptions{}.max_bias_instability_ug;
  const Diagnosis refused = diagnose_recording(rec, navigation_grade);
  EXPECT_EQ(refused.tau_floor_outcome, "refused");
  EXPECT_NE(refused.noise.how.find("beyond the bias instability of this class"), std::string::npos)
      << refused.noise.how;
  const UnitStaticRecordingUse refused_use = said_after(refused);
  EXPECT_EQ(refused_use.gave, "nothing");
  EXPECT_NE(refused_use.why.find("or longer, under which the diagnosis estimated a wander beyond "
                                 "its class of unit, not taken as noise"),
            std::string::npos)
      << refused_use.why;

  // A standcald run's header carries the floor: the diagnosis of the run takes it as the given
  // one, and a static recording given that puts none (0) comes before it.
  const test::TempDir dir;
  Recording carrying = rec;
  carrying.set_header(kHeaderUnitStaticTauFloorS, round_trip_text(floor_s));
  write_recording(carrying, dir.file("run.csv"));
  const Recording carried = read_recording(dir.file("run.csv"));
  const Diagnosis of_run = diagnose_recording(carried, no_floor);
  EXPECT_EQ(of_run.tau_floor_from, kWanderFromStaticRecording);
  EXPECT_EQ(of_run.noise.tau_given_min_s, floor_s) << of_run.noise.how;
  EXPECT_EQ(of_run.noise.tau_s, d.noise.tau_s);
  EXPECT_EQ(of_run.verdict, d.verdict);
  DiagnoseOptions none_given = given;
  none_given.unit_static_tau_floor_s = 0.0;
  EXPECT_TRUE(diagnose_recording(carried, none_given).tau_floor_from.empty());

  // A run of white noise: the revisits do not show the wander at those times; set aside.
  const Recording white = bench_run_with_warm_up(0, 0, 1200, kSlowRunSeed);
  const Diagnosis dw = diagnose_recording(white, given);
  EXPECT_EQ(dw.tau_floor_from, kWanderFromStaticRecording);
  EXPECT_EQ(dw.tau_floor_outcome, "set_aside");
  EXPECT_FALSE(dw.noise.tau_given_open_above) << dw.noise.how;
  EXPECT_NE(dw.noise.how.find("is set aside"), std::string::npos) << dw.noise.how;
  const UnitStaticRecordingUse white_use = said_after(dw);
  EXPECT_EQ(white_use.gave, "nothing");
  EXPECT_NE(white_use.why.find("or longer, a floor the diagnosis set aside: this run's positions "
                               "do not show the wander at those times"),
            std::string::npos)
      << white_use.why;

  // Nine positions cannot check the model: nothing was weighed under the floor, and said so (not
  // "set aside", which the first draft said).
  SimulationRequest nine;
  nine.program = paper9();
  nine.truth = default_truth();
  nine.seed = 9;
  const Diagnosis few = diagnose_recording(simulate_run(nine), given);
  EXPECT_EQ(few.tau_floor_outcome, "untested") << few.verdict;
  const UnitStaticRecordingUse few_use = said_after(few);
  EXPECT_EQ(few_use.gave, "nothing");
  EXPECT_NE(few_use.why.find("or longer, which the diagnosis did not weigh: it could not check the "
                             "model"),
            std::string::npos)
      << few_use.why;
}

// Where the run's rows do not show the wander at the floor's correlation times (below the bar
// of a finding), the floor is set aside, and said so: curves cannot tell a slow wander from a
// unit still settling after power-on, and a floor taken there had the fits weigh for a slow
// wander the run does not have (under white noise after a settling warm-up, sigmas 6-10x too
// large in one run of eight: docs/calibration.md). The fit is then the one without the floor.
TEST(FitNoise, AFloorUnderTheCorrelationTimeStandsOnlyWhereTheRunShowsTheWander) {
  const Recording rec = bench_run_with_warm_up(7200, 3, 1200, kUnpinnedWarmUpBelowBarSeed);
  const AveragedRecording averaged = average_recording(rec);
  ASSERT_TRUE(averaged.allan.has_value());
  ASSERT_FALSE(averaged.allan->wander.has_value());
  const double floor_s = averaged.allan->wander_tau_floor_s;
  ASSERT_GT(floor_s, 60);
  FitNoiseOptions noise;
  ASSERT_TRUE(take_recording_wander_or_bound(noise, averaged.allan));
  const FitResult set_aside = fit_full_vector(averaged.averages, noise);
  const FitResult unfloored = fit_full_vector(averaged.averages, FitNoiseOptions{});
  ASSERT_FALSE(unfloored.noise.bias_instability) << "the case this test is of";
  EXPECT_FALSE(set_aside.noise.tau_given_open_above) << set_aside.noise.how;
  EXPECT_NE(set_aside.noise.how.find("that a long static stretch's Allan curves put under the "
                                     "correlation time is set aside: this run's rows do not "
                                     "show the wander at those times"),
            std::string::npos)
      << set_aside.noise.how;
  for (int a = 0; a < 3; ++a) {
    const auto bias = static_cast<std::size_t>(a);
    EXPECT_DOUBLE_EQ(*set_aside.unit[bias].sigma, *unfloored.unit[bias].sigma) << "bias " << a;
  }
  // The diagnosis by the same rule, on its own between-visit rows.
  const Diagnosis d = diagnose_recording(rec);
  if (d.noise.tau_given_open_above)
    EXPECT_TRUE(d.noise.bias_instability) << d.noise.how;
  else
    EXPECT_NE(d.noise.how.find("is set aside"), std::string::npos) << d.noise.how;

  // Beside the unit's static recording, its words say the floor was set aside, after what the
  // fit made of the recording's own curves. Until 2026-12-07 they said the floor alone, before
  // the fit, as if it stood.
  FitResult beside;
  const UnitStaticRecordingUse use = static_recording_words_beside_a_floor(rec, averaged, beside);
  EXPECT_FALSE(beside.noise.tau_given_open_above) << beside.noise.how;
  const std::string set_aside_words = std::string(kRecordingTauFloorWords) +
                                      ", a floor this fit set aside: this run's dwells do not "
                                      "show the wander at those times";
  EXPECT_TRUE(use.why.ends_with(set_aside_words)) << use.why;
}

// The norm fit says the same of its static recording beside the floor its recording's warm-up
// puts under the correlation time: kept or set aside, as its fit did. Until 2026-12-07 it said
// the floor only where the static recording gave nothing, and then as if the floor stood.
TEST(FitNoise, TheNormFitsStaticRecordingWordsSayWhetherItKeptTheFloor) {
  // The first seed's intervals show the wander at the floor's times, the second's do not.
  for (const auto& [seed, kept] :
       {std::pair{kUnpinnedWarmUpSeed, true}, std::pair{kUnpinnedWarmUpBelowBarSeed, false}}) {
    const Recording rec = bench_run_with_warm_up(7200, 3, 1200, seed);
    NormCalibrationOptions options;
    options.stability = false;
    options.unit_static_recording = bench_static_recording(2, 0, 300, 32);
    const NormCalibration c = calibrate_without_angles(raw_input_of(rec), options);
    ASSERT_TRUE(c.unit_static_recording.has_value());
    const std::string& why = c.unit_static_recording->why;
    const NoiseFinding& noise = c.fit.result.noise;
    ASSERT_NE(why.find("; this recording's own long interval sees a wander it does not pin, whose "
                       "correlation time it bounds from below"),
              std::string::npos)
        << "seed " << seed << ": " << why;
    ASSERT_EQ(noise.tau_given_open_above, kept) << "the case this test is of: " << noise.how;
    EXPECT_EQ(why.find(", a floor this fit set aside: this run's intervals do not show the "
                       "wander at those times") != std::string::npos,
              !kept)
        << "seed " << seed << ": " << why;
    EXPECT_EQ(why.find("pins a wander"), std::string::npos) << "it pins none: " << why;
    EXPECT_EQ(why.find("record longer"), std::string::npos) << "its curves reach 60 s: " << why;
  }
}

// A unit with one quiet axis beside two that wander (x none, y 6 and z 12 ug, 60 s): x's curve
// cannot tell a wander from none, and its fitted size may be 0 by chance, which would weigh x
// with no wander at all whatever its curve allows. It is given the largest size its curve
// allows instead: above its fit, below the largest axis's, and said so. Until 2026-12-07 x was
// weighed at its fit (the first check fails so); before f96db55 at the largest axis's.
TEST(FitNoise, AnAxisWhoseCurveCannotTellAWanderFromNoneIsGivenTheLargestItAllows) {
  const UnitStaticAllan unit_static = two_hour_static_allan_of_axes(Vec3(0, 6, 12), 60, 50);
  ASSERT_TRUE(unit_static.allan.wander.has_value());
  const WanderToGive& pinned = *unit_static.allan.wander;
  ASSERT_TRUE(unit_static.gauss_markov.has_value());
  const GaussMarkovAllanFit& curves = *unit_static.gauss_markov;
  ASSERT_EQ(curves.q_min.size(), 3u);
  ASSERT_EQ(curves.q_min[0], 0) << "the case this test is of: x's curve allows no wander";
  EXPECT_GT(curves.q_min[1], 0);
  EXPECT_GT(curves.q_min[2], 0);
  const auto [averaged, noise, use] = run_given(unit_static, 51);
  ASSERT_TRUE(use.has_value());
  ASSERT_EQ(use->gave, "wander") << use->why;
  const Vec3 q = use->wander.axes_ug();
  EXPECT_DOUBLE_EQ(q[0], std::min(curves.q_max[0], pinned.q)) << q;
  EXPECT_GT(q[0], curves.q[0]) << "x's fit, " << curves.q[0] << " ug";
  EXPECT_LT(q[0], q[2]) << q;
  EXPECT_DOUBLE_EQ(q[1], curves.q[1]);
  EXPECT_DOUBLE_EQ(q[2], curves.q[2]);
  EXPECT_EQ(pinned.axes_at_bound, (std::vector<bool>{true, false, false}));
  EXPECT_NE(use->why.find("(x at the largest size its curve allows, at most the largest axis's: "
                          "it does not tell a wander from none)"),
            std::string::npos)
      << use->why;
  const FitResult fit = fit_full_vector(averaged.averages, noise);
  EXPECT_DOUBLE_EQ(fit.noise.wander_ug[0], q[0]) << fit.noise.how;
}

// A run whose own wander departs from the one specified because it is larger on some axis is
// weighted with its own there, and the specified one on the axes where its own is smaller:
// it was judged at the laxer bar (specified_exceeded_p), which says nothing of those. Here the
// norm fit is given the wander a two-hour warm-up's curves pin (31.6 ug simulated, 10x, tau
// 300 s), and the run departs (P = 0.006). Until 2026-12-06 the run's own was taken on every
// axis: z's 0.4 ug, whose bias then came out 9.7 sigma off (both checks fail so).
TEST(FitNoise, ARunThatDepartsUpwardsKeepsTheSpecifiedWanderOnItsQuieterAxes) {
  const Recording rec = bench_run_with_warm_up(7200, 10, 300, 238);
  const NormCalibration norm = norm_fit_taking_the_warm_ups_wander(rec);
  const NoiseFinding& n = norm.fit.result.noise;
  ASSERT_NE(n.how.find("departs from the specified"), std::string::npos)
      << "the case this test is of: " << n.how;
  const std::optional<AllanFinding>& allan = n.allan;
  ASSERT_TRUE(allan && allan->wander) << n.how;
  ASSERT_EQ(allan->wander->q_axes.size(), 3u);
  for (int a = 0; a < 3; ++a)
    EXPECT_GE(n.wander_ug[a], allan->wander->q_axes[static_cast<std::size_t>(a)] * (1 - 1e-9)) << a;
  EXPECT_NE(n.how.find("the specified one on the axes where the run's is smaller"),
            std::string::npos)
      << n.how;
  for (int a = 0; a < 3; ++a) {
    const ParameterEstimate& b = norm.fit.result.unit[static_cast<std::size_t>(a)];
    EXPECT_LT(std::abs(*b.value - default_truth().unit.bias_g[a]), 4 * *b.sigma) << a;
  }
  // The reports, the JSON and the diagnosis's words say which axes' sizes are the given one, not
  // the run's. Until 2026-12-07 they printed them as the run's (session 35's review, item 14).
  // An axis kept the given size exactly; one that did not has its own, larger.
  for (std::size_t a = 0; a < 3; ++a) {
    const double given = allan->wander->q_axes[a], weighted = n.wander_ug[static_cast<int>(a)];
    EXPECT_EQ(n.wander_axes_specified[a], std::abs(weighted - given) <= 1e-9 * given)
        << "axis " << a << ": " << weighted << " ug weighted, " << given << " ug given";
  }
  ASSERT_TRUE(n.wander_axes_specified[2]) << "z's 0.4 ug is below the given";
  const std::string words = specified_axes_words(n);
  EXPECT_NE(words.find("z at the given size (this run's own is smaller there)"), std::string::npos)
      << words;
  const RawInput in = raw_input_of(rec);
  const std::string report = format_norm_report(norm, in);
  EXPECT_NE(report.find(" s, estimated)" + words + ", weighted for"), std::string::npos) << report;
  EXPECT_NE(noise_line(n, false).find(" ug (x/y/z)" + words + ", tau "), std::string::npos)
      << noise_line(n, false);
  const std::string diagnosis_words = diagnosis::noise_words(n);
  EXPECT_NE(diagnosis_words.find(" ug" + words + ", correlation time "), std::string::npos)
      << diagnosis_words;
  const nlohmann::json flags = norm_calibration_to_json(norm, in)["noise"]["wander_axes_specified"];
  EXPECT_EQ(flags, nlohmann::json::array({n.wander_axes_specified[0], n.wander_axes_specified[1],
                                          n.wander_axes_specified[2]}));
}
