// The bias-wander noise model (calib/noise_model): its Kalman-filter decorrelation is the
// Cholesky factor's inverse; its REML estimate finds wander that is there and (at about
// its nominal rate) none that is not; its Allan peak matches a simulated Allan curve.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <random>

#include "calib/allan.hpp"
#include "calib/noise_model.hpp"
#include "tests/support/statistical.hpp"

namespace standcal {
namespace {

using Eigen::MatrixXd;
using Eigen::VectorXd;

// 32 dwells 12 s apart, three full-vector rows each, and one invariant-like row with a
// mixed projection, sigmas 3 ug give or take.
std::vector<NoiseRow> rows_of_a_run(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<NoiseRow> rows;
  for (int k = 0; k < 32; ++k) {
    const double t = 6 + 12.0 * k;
    for (int a = 0; a < 3; ++a) rows.push_back({t, Vec3::Unit(a), (3 + u(rng)) * 1e-6});
    rows.push_back({t, Vec3(u(rng), u(rng), u(rng)).normalized(), (3 + u(rng)) * 1e-6});
  }
  std::shuffle(rows.begin(), rows.end(), rng);  // the filter must not rely on the rows' order
  return rows;
}

MatrixXd whitened_covariance(const std::vector<NoiseRow>& rows, const GaussMarkovNoise& n) {
  const auto m = static_cast<Eigen::Index>(rows.size());
  MatrixXd C = MatrixXd::Identity(m, m);
  for (Eigen::Index r = 0; r < m; ++r)
    for (Eigen::Index s = 0; s < m; ++s) {
      const NoiseRow &a = rows[static_cast<std::size_t>(r)], &b = rows[static_cast<std::size_t>(s)];
      const double rho = std::exp(-std::abs(a.t_s - b.t_s) / n.tau_s);
      double c = 0;
      for (int ax = 0; ax < 3; ++ax)
        c += a.projection[ax] * b.projection[ax] * n.q_g[ax] * n.q_g[ax] * rho;
      C(r, s) += c / (a.sigma_g * b.sigma_g);
    }
  return C;
}

TEST(NoiseModel, DecorrelationIsTheInverseCholeskyFactor) {
  std::mt19937_64 rng(21);
  const std::vector<NoiseRow> rows = rows_of_a_run(rng);
  const GaussMarkovNoise noise{Vec3(2e-6, 5e-6, 1e-6), 300};
  const MatrixXd C = whitened_covariance(rows, noise);
  const MatrixXd M = MatrixXd::Random(static_cast<Eigen::Index>(rows.size()), 4);
  double log_det = 0;
  const MatrixXd Z = decorrelate(rows, noise, M, &log_det);
  // Any square root W of C^{-1} with Z = W M gives Z^T Z = M^T C^{-1} M; the log det must agree.
  EXPECT_LT((Z.transpose() * Z - M.transpose() * C.llt().solve(M)).norm(),
            1e-9 * (M.transpose() * M).norm());
  const Eigen::LLT<MatrixXd> llt(C);
  const double expected_log_det = 2 * llt.matrixL().toDenseMatrix().diagonal().array().log().sum();
  EXPECT_NEAR(log_det, expected_log_det, 1e-9);
  EXPECT_EQ(decorrelate(rows, GaussMarkovNoise{}, M), M);  // white noise: nothing to do
}

// The wander's correlation between the means over two windows, by the midpoint rule on a
// fine grid of each: the closed forms' check.
double window_correlation_by_quadrature(const NoiseRow& a, const NoiseRow& b, double tau_s) {
  constexpr int kPoints = 400;
  const auto at = [](const NoiseRow& r, int i) {
    return r.t_s + r.window_s * ((i + 0.5) / kPoints - 0.5);
  };
  double sum = 0;
  for (int i = 0; i < kPoints; ++i)
    for (int j = 0; j < kPoints; ++j) sum += std::exp(-std::abs(at(a, i) - at(b, j)) / tau_s);
  return sum / (kPoints * kPoints);
}

// A dwell mean is the wander's mean over the dwell, not its value at the mid-time: for dwells
// long against tau the two differ wholly, and for 10 s dwells 30 s apart at tau = 300 s the
// value at mid-time overstates how much consecutive means differ by 13 %, which made the
// wander's size fitted to them 12 % too small in variance (docs/calibration.md). Dwells of
// 1-200 s at tau = 60 s; this failed before (the means taken as values at their mid-times).
TEST(NoiseModel, ARowIsTheWandersMeanOverItsDwellNotItsValueAtMidTime) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<NoiseRow> rows;
  double t = 0;
  for (int k = 0; k < 12; ++k) {
    const double window_s = k == 0 ? 0.0 : 1 + 199 * u(rng) * u(rng);
    const double mid_s = t + 0.5 * window_s;
    for (int a = 0; a < 3; ++a)
      rows.push_back({mid_s, Vec3::Unit(a), (2 + u(rng)) * 1e-6, window_s});
    rows.push_back(
        {mid_s, Vec3(u(rng), -u(rng), u(rng)).normalized(), (2 + u(rng)) * 1e-6, window_s});
    t += window_s + 5 + 35 * u(rng);
  }
  std::shuffle(rows.begin(), rows.end(), rng);
  const GaussMarkovNoise noise{Vec3(4e-6, 7e-6, 3e-6), 60};
  const auto m = static_cast<Eigen::Index>(rows.size());
  MatrixXd expected = MatrixXd::Zero(m, m);
  std::map<std::pair<double, double>, double> by_dwells;  // four rows a dwell: each pair once
  for (Eigen::Index r = 0; r < m; ++r)
    for (Eigen::Index s = 0; s <= r; ++s) {
      const NoiseRow &a = rows[static_cast<std::size_t>(r)], &b = rows[static_cast<std::size_t>(s)];
      const auto dwells = std::minmax(a.t_s, b.t_s);
      if (!by_dwells.count(dwells))
        by_dwells[dwells] = window_correlation_by_quadrature(a, b, noise.tau_s);
      const double k_ab = by_dwells[dwells];
      expected(r, s) = expected(s, r) =
          a.projection.cwiseProduct(b.projection).dot(noise.q_g.cwiseAbs2()) * k_ab +
          (r == s ? a.sigma_g * a.sigma_g : 0.0);
    }
  EXPECT_LT((row_covariance(rows, noise) - expected).norm(), 1e-4 * expected.norm());
  VectorXd w(m);
  for (Eigen::Index r = 0; r < m; ++r) w[r] = 1 / rows[static_cast<std::size_t>(r)].sigma_g;
  double log_det = 0;
  const MatrixXd K = decorrelate(rows, noise, MatrixXd::Identity(m, m), &log_det);
  const MatrixXd whitened = K * w.asDiagonal() * expected * w.asDiagonal() * K.transpose();
  EXPECT_LT((whitened - MatrixXd::Identity(m, m)).norm(), 1e-3);
  const Eigen::LLT<MatrixXd> llt(w.asDiagonal() * expected * w.asDiagonal());
  EXPECT_NEAR(log_det, 2 * llt.matrixL().toDenseMatrix().diagonal().array().log().sum(), 1e-3);
}

// y = X beta + noise drawn from `noise` (exactly, through the dense covariance).
VectorXd draw(const std::vector<NoiseRow>& rows, const GaussMarkovNoise& noise,
              std::mt19937_64& rng) {
  std::normal_distribution<double> n01(0, 1);
  VectorXd z(static_cast<Eigen::Index>(rows.size()));
  for (Eigen::Index i = 0; i < z.size(); ++i) z[i] = n01(rng);
  if (noise.white()) return z;
  return whitened_covariance(rows, noise).llt().matrixL() * z;
}

// The model's columns: a bias per axis and a scale-like column, whitened.
MatrixXd design(const std::vector<NoiseRow>& rows) {
  MatrixXd X(static_cast<Eigen::Index>(rows.size()), 4);
  for (std::size_t r = 0; r < rows.size(); ++r) {
    const auto i = static_cast<Eigen::Index>(r);
    X.row(i).head(3) = rows[r].projection.transpose() / rows[r].sigma_g;
    X(i, 3) = rows[r].projection.squaredNorm() * std::cos(rows[r].t_s) / rows[r].sigma_g;
  }
  return X;
}

TEST(NoiseModel, WhiteNoiseIsRarelyTakenForWander) {
  STANDCAL_STATISTICAL_TEST();
  std::mt19937_64 rng(7);
  int significant = 0;
  constexpr int kTrials = 100;
  for (int i = 0; i < kTrials; ++i) {
    const std::vector<NoiseRow> rows = rows_of_a_run(rng);
    significant +=
        estimate_bias_wander(rows, design(rows), draw(rows, {}, rng)).significant ? 1 : 0;
  }
  // Nominal P = 1e-3 (chi2 with 4 parameters at 18.5; at the boundary q = 0 it is less).
  EXPECT_LE(significant, 3);
}

TEST(NoiseModel, WanderOfTheSizeOfTheWhiteErrorIsFoundAndSized) {
  STANDCAL_STATISTICAL_TEST();
  std::mt19937_64 rng(8);
  const GaussMarkovNoise truth{Vec3(4e-6, 4e-6, 4e-6), 300};
  int significant = 0;
  double log_ratio_sum = 0;
  constexpr int kTrials = 40;
  for (int i = 0; i < kTrials; ++i) {
    const std::vector<NoiseRow> rows = rows_of_a_run(rng);
    const NoiseEstimate e = estimate_bias_wander(rows, design(rows), draw(rows, truth, rng));
    significant += e.significant ? 1 : 0;
    log_ratio_sum += std::log(std::max(e.best.q_g.mean(), 1e-9) / truth.q_g.mean());
  }
  EXPECT_GE(significant, 3 * kTrials / 4);
  // One short run fixes q only roughly; on average within a factor 1.5 of the truth.
  EXPECT_LT(std::abs(log_ratio_sum / kTrials), std::log(1.5));
}

// A wander common to the three axes is estimated as one q: an axis gets its own only where
// its rows demand it (NoiseEstimateOptions::axis_lr), as the z axis without any wander here.
// Taking every small gain split the common q on nearly every run (40 of 40 before the rule),
// and an axis whose q came out low by chance had too small a bias sigma.
TEST(NoiseModel, AnAxisGetsItsOwnWanderOnlyWhereItsRowsDemandIt) {
  STANDCAL_STATISTICAL_TEST();
  std::mt19937_64 rng(10);
  constexpr int kTrials = 40;
  const GaussMarkovNoise common{Vec3(4e-6, 4e-6, 4e-6), 300};
  int split = 0;
  for (int i = 0; i < kTrials; ++i) {
    const std::vector<NoiseRow> rows = rows_of_a_run(rng);
    const Vec3 q = estimate_bias_wander(rows, design(rows), draw(rows, common, rng)).best.q_g;
    split += q.maxCoeff() > q.minCoeff() ? 1 : 0;
  }
  // Nominal P = 0.01 per axis (1e-3 for a q below the common one); more where the axes'
  // wanders differ by chance.
  EXPECT_LE(split, kTrials / 4);
  const GaussMarkovNoise no_z{Vec3(12e-6, 12e-6, 0), 300};
  int z_apart = 0;
  double log_ratio_xy = 0;
  for (int i = 0; i < kTrials; ++i) {
    const std::vector<NoiseRow> rows = rows_of_a_run(rng);
    const Vec3 q = estimate_bias_wander(rows, design(rows), draw(rows, no_z, rng)).best.q_g;
    z_apart += q[2] < 0.5 * std::min(q[0], q[1]) ? 1 : 0;
    log_ratio_xy += std::log(std::max(q[0] * q[1], 1e-18) / (12e-6 * 12e-6)) / 2;
  }
  // 28 of 40 at the bar for a quieter axis (P = 1e-3), 35 at P = 0.01: what that stricter
  // bar costs, against an axis left without wander by chance (noise_honesty_test.cpp).
  EXPECT_GE(z_apart, 5 * kTrials / 8);
  // x and y get the q they share once z has left the common one, not the compromise with a
  // quiet z: their geometric mean over these runs is 0.89 of the truth, 0.75 without the
  // re-fit (failed before, bound 1.25).
  EXPECT_LT(std::abs(log_ratio_xy / kTrials), std::log(1.25)) << std::exp(log_ratio_xy / kTrials);
}

// An axis that left the common q has its own scale, pinned by its own rows only: a
// parameter whose variance rests on that axis's q gets the degrees of freedom of that scale's
// information (nu = 2 I for a variance proportional to q^2), not the common scale's.
TEST(NoiseModel, AParameterOnAnAxisOwnWanderHasThatScalesDegreesOfFreedom) {
  FitNoiseChoice choice;
  choice.noise = {Vec3(20e-6, 8e-6, 8e-6), 300};
  choice.scales.axes = {Vec3(0, 1, 1), Vec3(1, 0, 0)};  // the common q of y and z; x's own
  choice.scales.information = (Eigen::Matrix2d() << 50, 0, 0, 2).finished();
  // Parameter 0 rests on x's wander alone, parameter 1 on y's, parameter 2 on neither.
  const auto variances = [](const GaussMarkovNoise& n) {
    return Eigen::Vector3d(n.q_g[0] * n.q_g[0], n.q_g[1] * n.q_g[1], 1e-12);
  };
  const SigmaWidening w = widen_for_estimated_noise(variances, choice);
  // Central differences of e^u with a step of 0.2 read the slope 0.7 % high.
  EXPECT_NEAR(w.dof[0], 2 * 2, 0.1);
  EXPECT_NEAR(w.dof[1], 2 * 50, 2);
  EXPECT_FALSE(std::isfinite(w.dof[2]));
  EXPECT_NEAR(w.factor[0], student_t_inflation(w.dof[0]), 1e-12);
  EXPECT_DOUBLE_EQ(w.factor[2], 1.0);
}

// Two scales the run pins jointly (a cross term in their information): a parameter resting
// on both gets nu = 2 var^2 / (g' I^-1 g); and a cross term too large for I to be positive
// definite leaves the scales taken one by one.
TEST(NoiseModel, TheDegreesOfFreedomTakeTheScalesCrossInformation) {
  FitNoiseChoice choice;
  choice.noise = {Vec3(10e-6, 10e-6, 10e-6), 300};
  choice.scales.axes = {Vec3(1, 1, 0), Vec3(0, 0, 1)};
  const auto variances = [](const GaussMarkovNoise& n) {
    return Eigen::Vector2d(n.q_g[0] * n.q_g[0] + n.q_g[2] * n.q_g[2], 1e-12);
  };
  // var = e^u1 q^2 + e^u2 q^2 at u = 0: g = (q^2, q^2) (read 0.7 % high by the differences).
  const double var = 2e-10, g = 1e-10 * std::sinh(0.2) / 0.2;
  choice.scales.information = (Eigen::Matrix2d() << 2, 1, 1, 2).finished();
  const double g_i_g = g * g * (2 - 1 - 1 + 2) / 3.0;  // g' I^-1 g, I^-1 = [2 -1; -1 2] / 3
  EXPECT_NEAR(widen_for_estimated_noise(variances, choice).dof[0], 2 * var * var / g_i_g, 1e-9);
  choice.scales.information = (Eigen::Matrix2d() << 2, 3, 3, 2).finished();
  EXPECT_NEAR(widen_for_estimated_noise(variances, choice).dof[0],
              2 * var * var / (g * g * (0.5 + 0.5)), 1e-9);
}

// The free scales of an estimate are the axes it shares a q over and each axis with its own:
// one scale per axis with a wander, none for an axis left without.
TEST(NoiseModel, TheEstimatesScalesCoverEachAxisWithAWanderOnce) {
  std::mt19937_64 rng(10);
  const GaussMarkovNoise no_z{Vec3(12e-6, 12e-6, 0), 300};
  int apart = 0;
  for (int i = 0; i < 10; ++i) {
    const std::vector<NoiseRow> rows = rows_of_a_run(rng);
    const NoiseEstimate e = estimate_bias_wander(rows, design(rows), draw(rows, no_z, rng));
    ASSERT_FALSE(e.best.white());
    Vec3 covered = Vec3::Zero();
    for (const Vec3& axes : e.scales.axes) covered += axes;
    for (int a = 0; a < 3; ++a)
      EXPECT_EQ(covered[a], e.best.q_g[a] > 0 ? 1.0 : 0.0) << "run " << i << " axis " << a;
    ASSERT_EQ(e.scales.information.rows(), static_cast<Eigen::Index>(e.scales.axes.size()));
    EXPECT_TRUE(e.scales.information.isApprox(e.scales.information.transpose()));
    EXPECT_TRUE((e.scales.information.diagonal().array() > 0).all());
    const bool z_apart = e.best.q_g[2] < 0.5 * e.best.q_g[0];
    apart += z_apart ? 1 : 0;
    if (z_apart && e.best.q_g[2] == 0)
      EXPECT_EQ(e.scales.axes.front(), Vec3(1, 1, 0)) << "run " << i;
  }
  EXPECT_GE(apart, 5);  // the case the scales are for: 28 of 40 in the test above
}

TEST(NoiseModel, AllanPeakMatchesASimulatedGaussMarkovCurve) {
  const double q = 3.0, tau = 50, dt = 1;
  const AllanPeak peak = gauss_markov_allan_peak(q, tau);
  std::mt19937_64 rng(9);
  std::normal_distribution<double> n01(0, 1);
  const double a = std::exp(-dt / tau);
  std::vector<double> x(400000);
  double b = q * n01(rng);
  for (double& v : x) {
    b = a * b + q * std::sqrt(1 - a * a) * n01(rng);
    v = b;
  }
  double simulated_peak = 0;
  for (const AllanPoint& p : overlapping_allan_deviation({x}, dt, 20))
    if (p.tau_s > 10 && p.tau_s < 1000) simulated_peak = std::max(simulated_peak, p.deviation);
  EXPECT_NEAR(simulated_peak, peak.deviation, 0.05 * peak.deviation);
  EXPECT_GT(peak.tau_s, tau);
  EXPECT_LT(peak.tau_s, 3 * tau);
}

}  // namespace
}  // namespace standcal
