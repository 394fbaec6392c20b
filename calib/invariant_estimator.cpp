#include "calib/invariant_estimator.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>

#include "calib/full_estimator.hpp"
#include "calib/identifiability.hpp"
#include "calib/units.hpp"

namespace standcal {

namespace {

using Eigen::MatrixXd;
using Eigen::VectorXd;

// What multiplies each parameter in delta_J_L, for plain-language reasons.
constexpr const char* kRegressorText[kUnitParameterCount] = {
    "u_x", "u_y", "u_z", "u_x^2", "u_y^2", "u_z^2", "u_x*u_y", "u_x*u_z", "u_y*u_z"};

struct InvariantData {
  MatrixXd H;      // n x 9 regressors
  VectorXd y;      // delta_J_L per position, in g
  VectorXd sigma;  // its standard error
};

InvariantData invariant_data(const std::vector<PositionAverage>& positions) {
  const Eigen::Index n = static_cast<Eigen::Index>(positions.size());
  InvariantData d{MatrixXd(n, kUnitParameterCount), VectorXd(n), VectorXd(n)};
  for (Eigen::Index k = 0; k < n; ++k) {
    const PositionAverage& p = positions[static_cast<std::size_t>(k)];
    const Vec3 u = p.up();
    d.H.row(k) = invariant_regressor(u);
    d.y[k] = delta_J_L(u, p.mean_g);
    d.sigma[k] = invariant_sigma_g(p);
  }
  return d;
}

// Parameters outside the column space the programme can resolve, each with a reason.
std::vector<std::string> unobservable_reasons(const InvariantData& d) {
  std::vector<std::string> reasons(kUnitParameterCount);
  MatrixXd A = d.sigma.cwiseInverse().asDiagonal() * d.H;
  for (int j = 0; j < kUnitParameterCount; ++j) {
    if (d.H.col(j).norm() < 1e-9 * std::sqrt(static_cast<double>(d.H.rows()))) {
      reasons[j] = std::string(kRegressorText[j]) +
                   " is zero at every position of this programme, so delta_J_L does not "
                   "depend on " +
                   std::string(kUnitParameterNames[j]);
      A.col(j).setZero();
    } else {
      A.col(j).normalize();
    }
  }
  Eigen::JacobiSVD<MatrixXd> svd(A, Eigen::ComputeFullV);
  const VectorXd& s = svd.singularValues();
  const double tol = 1e-8 * std::max(1.0, s.size() ? s[0] : 0.0);
  for (Eigen::Index k = 0; k < kUnitParameterCount; ++k) {
    const double sk = k < s.size() ? s[k] : 0.0;
    if (sk > tol) continue;
    const VectorXd v = svd.matrixV().col(k);
    std::string combo;
    for (int j = 0; j < kUnitParameterCount; ++j)
      if (std::abs(v[j]) > 1e-6 && reasons[j].empty())
        combo += (combo.empty() ? "" : ", ") + std::string(kUnitParameterNames[j]);
    for (int j = 0; j < kUnitParameterCount; ++j)
      if (std::abs(v[j]) > 1e-6 && reasons[j].empty())
        reasons[j] = "this programme determines only a combination of " + combo +
                     ", not each one (their regressors in delta_J_L are linearly dependent)";
  }
  return reasons;
}

MatrixXd fitted_columns(const InvariantData& d, const std::vector<int>& fitted) {
  MatrixXd H(d.H.rows(), static_cast<Eigen::Index>(fitted.size()));
  for (std::size_t c = 0; c < fitted.size(); ++c)
    H.col(static_cast<Eigen::Index>(c)) = d.H.col(fitted[c]);
  return H;
}

// The rows of delta_J_L for the noise model.
std::vector<NoiseRow> noise_rows_of(const InvariantData& d,
                                    const std::vector<PositionAverage>& positions) {
  return invariant_noise_rows(positions,
                              std::vector<double>(d.sigma.data(), d.sigma.data() + d.sigma.size()));
}

// chi2 of the estimate x = L y's residuals under a noise model.
double chi2_against(const InvariantData& d, const std::vector<PositionAverage>& positions,
                    const std::vector<int>& fitted, const MatrixXd& L,
                    const GaussMarkovNoise& noise) {
  const VectorXd residual = d.y - fitted_columns(d, fitted) * (L * d.y);
  return decorrelate(noise_rows_of(d, positions), noise, residual.cwiseQuotient(d.sigma))
      .squaredNorm();
}

// Fills everything derived from a linear estimate x = L y, Cov(y) from the noise model.
void finish_linear_fit(const InvariantData& d, const std::vector<PositionAverage>& positions,
                       const MatrixXd& L, const std::vector<int>& fitted,
                       const GaussMarkovNoise& noise, FitResult& r) {
  const VectorXd x = L * d.y;
  const std::vector<NoiseRow> rows = noise_rows_of(d, positions);
  const MatrixXd cov = L * row_covariance(rows, noise) * L.transpose();
  const VectorXd residual = d.y - fitted_columns(d, fitted) * x;

  r.positions = static_cast<int>(positions.size());
  r.parameters_estimated = static_cast<int>(fitted.size());
  r.redundancy = r.positions - r.parameters_estimated;
  r.chi2 = chi2_against(d, positions, fitted, L, noise);
  r.chi2_dof = r.redundancy > 0 ? r.chi2 / r.redundancy : kNaN;
  r.residual_rms_g = std::sqrt(residual.squaredNorm() / static_cast<double>(residual.size()));
  r.correlation = MatrixXd::Constant(kUnitParameterCount, kUnitParameterCount, kNaN);
  for (std::size_t a = 0; a < fitted.size(); ++a) {
    const auto ia = static_cast<Eigen::Index>(a);
    r.unit[static_cast<std::size_t>(fitted[a])].value = x[ia];
    r.unit[static_cast<std::size_t>(fitted[a])].sigma = std::sqrt(cov(ia, ia));
    for (std::size_t b = 0; b < fitted.size(); ++b) {
      const auto ib = static_cast<Eigen::Index>(b);
      r.correlation(fitted[a], fitted[b]) = cov(ia, ib) / std::sqrt(cov(ia, ia) * cov(ib, ib));
    }
  }
  for (std::size_t k = 0; k < positions.size(); ++k) {
    const auto ik = static_cast<Eigen::Index>(k);
    PositionResidual pr;
    pr.pos = positions[k].pos;
    pr.alpha1_cmd_deg = positions[k].alpha1_cmd_deg;
    pr.alpha2_cmd_deg = positions[k].alpha2_cmd_deg;
    pr.mount = positions[k].mount;
    pr.residual_g = VectorXd::Constant(1, residual[ik]);
    pr.sigma_g = VectorXd::Constant(1, d.sigma[ik]);
    r.residuals.push_back(pr);
  }
  if (r.redundancy == 0)
    r.notes.push_back("Zero redundancy: " + std::to_string(r.positions) + " positions for " +
                      std::to_string(r.parameters_estimated) +
                      " parameters. The fit is exact (residuals are zero by construction), so "
                      "it cannot reveal a wrong model; add positions to check it.");
}

// Weighted least-squares map P with x = P r for rows `rows` of H, columns `cols`.
MatrixXd weighted_ls_map(const InvariantData& d, const std::vector<Eigen::Index>& rows,
                         const std::vector<int>& cols) {
  MatrixXd A(static_cast<Eigen::Index>(rows.size()), static_cast<Eigen::Index>(cols.size()));
  VectorXd w(static_cast<Eigen::Index>(rows.size()));
  for (std::size_t i = 0; i < rows.size(); ++i) {
    for (std::size_t j = 0; j < cols.size(); ++j)
      A(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j)) = d.H(rows[i], cols[j]);
    w[static_cast<Eigen::Index>(i)] = 1.0 / d.sigma[rows[i]];
  }
  const MatrixXd Aw = w.asDiagonal() * A;
  // x = (Aw^T Aw)^-1 Aw^T (w .* r), via a rank-revealing QR for conditioning.
  return Aw.colPivHouseholderQr().solve(MatrixXd(w.asDiagonal()));
}

// The generalised least-squares map over all rows: the whitened problem decorrelated by
// the noise model's C^{-1/2} (Kalman innovations), then solved as above.
MatrixXd gls_map(const InvariantData& d, const std::vector<PositionAverage>& positions,
                 const std::vector<int>& fitted, const GaussMarkovNoise& noise) {
  const std::vector<NoiseRow> rows = noise_rows_of(d, positions);
  const VectorXd w = d.sigma.cwiseInverse();
  const MatrixXd Aw = decorrelate(rows, noise, w.asDiagonal() * fitted_columns(d, fitted));
  const MatrixXd Dw = decorrelate(rows, noise, MatrixXd(w.asDiagonal()));
  return Aw.colPivHouseholderQr().solve(Dw);
}

// Each sigma widened for the uncertainty of an estimated wander (noise_model.hpp).
void widen_sigmas(const InvariantData& d, const std::vector<PositionAverage>& positions,
                  const std::vector<int>& fitted, const FitNoiseChoice& noise, FitResult& r) {
  const std::vector<NoiseRow> rows = noise_rows_of(d, positions);
  const MatrixXd Aw = d.sigma.cwiseInverse().asDiagonal() * fitted_columns(d, fitted);
  const SigmaWidening widen = standcal::widen_for_estimated_noise(
      [&](const GaussMarkovNoise& n) {
        const MatrixXd A = decorrelate(rows, n, Aw);
        const MatrixXd info = A.transpose() * A;
        return VectorXd(info.ldlt().solve(MatrixXd::Identity(info.rows(), info.cols())).diagonal());
      },
      noise);
  for (std::size_t a = 0; a < fitted.size(); ++a) {
    ParameterEstimate& p = r.unit[static_cast<std::size_t>(fitted[a])];
    p.dof = widen.dof[static_cast<Eigen::Index>(a)];
    if (p.sigma) *p.sigma *= widen.factor[static_cast<Eigen::Index>(a)];
  }
}

// 2 delta log L against white noise above which the full vector's wander is taken even
// below the bar of a finding: chi2 with two parameters (a q common to the axes, and tau) at
// P = 0.05. Weaker estimates, taken as well, only widened white noise's sigmas (an
// 18-position programme's z-variance fell to 0.70-0.75); without the sub-threshold ones the
// biases' z-variance was 1.10-1.52 under a wander of 1x the dwell error (0.94-1.05 with).
constexpr double kFullVectorWanderLr = 5.99;

// Whether the invariant fit weights with the wander the full vector estimated: a finding
// (weighted as the specified wander where it agrees with one), or evident (kFullVectorWanderLr).
// With the correlation time given as one value, any wander the full vector weights for: there only
// q is estimated, with no average over the times the run allows to widen the biases' sigmas, and
// under a 1x wander the joint fit's biases were at 1.31-1.51 in z-variance with the evident ones
// alone (1000 runs; 1.09-1.17 taking every one, as the full vector's own 1.09-1.19; white noise's
// 0.90-0.93 -> 0.83-0.89).
bool takes_full_vector_wander(const FitNoiseChoice& full, const FitNoiseOptions& options) {
  if (full.noise.white()) return false;
  if (full.finding.bias_instability) return true;  // estimated, or agreeing with the specified
  if (full.finding.source != "estimated") return false;
  // A floor set aside is no correlation time given (FitNoiseChoice::tau_floor_set_aside).
  const bool one_tau_given =
      options.known_tau && !options.known_tau->range() && !full.tau_floor_set_aside;
  return one_tau_given || full.finding.lr > kFullVectorWanderLr;
}

// The full vector's choice as the invariant fit takes it: said so in `how` (with `why`), and
// with no noise parameter of its own rows to cost its chi-square test a degree of freedom.
FitNoiseChoice taken_from_full_vector(FitNoiseChoice full, const std::string& why = "") {
  full.finding.how = "from the full vector of the dwell means (3 rows per position)" + why + ": " +
                     full.finding.how;
  full.parameters = 0;
  return full;
}

// 2 delta log L by which the full vector of the dwell means must favour white noise over a
// wander the invariant rows estimated, for that wander to be set aside: a likelihood ratio of
// e^1.92 = 6.8 between two given models (not a nested fit, so no chi-square level applies;
// were the wander the true one, its rows would favour white noise so in at most 1/6.8 = 15 %
// of runs).
constexpr double kFullVectorRejectsLr = 3.84;

// The invariant rows' own wander, weighted below the bar of a finding where the full vector
// weighs none or one below the evident bar, as the full vector's three rows per position
// receive it: a wander they disfavour against white noise (kFullVectorRejectsLr) gives way
// to the full vector's own choice, white or weighted (taking the latter always had made an
// 18-position programme's white-noise sigmas too wide, kFullVectorWanderLr; taken only where
// the joint rows' own is disfavoured, it did not), and of the correlation times the biases'
// sigmas are averaged over, those they disfavour are dropped. From 24 rows of a white unit's
// classic24 run the invariant rows proposed wanders of 5-16 ug (tau 150-1200 s) that the full
// vector's 72 disfavoured by 3.9-21 in 2 delta log L (their own estimate: none, or 2 delta
// log L 1.1-5.6, below the evident bar), and the biases' sigmas came out 9.6-25 ug against
// white noise's 1.1.
FitNoiseChoice checked_by_full_vector(const WanderAgainstWhite& against, FitNoiseChoice full,
                                      FitNoiseChoice own, const FitNoiseOptions& options) {
  const auto disfavoured = [&](const GaussMarkovNoise& n) {
    return against(n) > kFullVectorRejectsLr;
  };
  if (disfavoured(own.noise))
    return taken_from_full_vector(std::move(full),
                                  ", which disfavour the wander the invariant rows estimate");
  std::erase_if(own.plausible, [&](const PlausibleNoise& p) { return disfavoured(p.noise); });
  set_tau_provenance(own.finding, own.plausible,
                     own.tau_floor_set_aside ? std::nullopt : options.known_tau);
  return own;
}

// A wander that the full vector of the same dwell means shows, as a finding or evidently
// (takes_full_vector_wander), is weighted for as the full-vector fit estimates it: three rows
// per position pin it better than the invariant projection's one (docs/calibration.md,
// "Noise model"). Otherwise the invariant rows estimate it themselves, as when there is no
// full vector, and the full vector's rows judge that estimate (checked_by_full_vector). The
// chi-square of the invariant residuals loses no degree of freedom to a wander fitted to the
// full vector's rows.
FitNoiseChoice invariant_noise_choice(const InvariantData& d,
                                      const std::vector<PositionAverage>& positions,
                                      const std::vector<int>& fitted,
                                      const VectorXd& white_residual,
                                      const FitNoiseOptions& options) {
  std::optional<FitNoiseChoice> full;
  WanderAgainstWhite against;
  if (options.mode == FitNoiseOptions::Mode::estimate && options.estimate_from_full_vector) {
    full = full_vector_noise_choice(positions, options, &against);
    if (full && takes_full_vector_wander(*full, options)) return taken_from_full_vector(*full);
  }
  FitNoiseChoice own = choose_fit_noise(
      noise_rows_of(d, positions), d.sigma.cwiseInverse().asDiagonal() * fitted_columns(d, fitted),
      white_residual.cwiseQuotient(d.sigma), options, positions);
  // Only a wander weighted below the bar of a finding is judged; a full vector with too few
  // rows to estimate one (lr_threshold 0), or whose model does not fit (no judge), is none.
  const bool weighted_below_bar =
      own.finding.source == "estimated" && !own.noise.white() && !own.finding.bias_instability;
  if (full && full->finding.lr_threshold > 0 && against && weighted_below_bar)
    return checked_by_full_vector(against, *full, own, options);
  return own;
}

}  // namespace

double invariant_sigma_g(const PositionAverage& p) {
  const Vec3 u = p.up();
  const double var = u.cwiseAbs2().dot(p.standard_error_g.cwiseAbs2());
  return std::max(std::sqrt(var), kInvariantSigmaFloor_g);
}

FitResult fit_invariant_joint(const std::vector<PositionAverage>& positions) {
  return fit_invariant_joint(positions, FitNoiseOptions{});
}

FitResult fit_invariant_joint(const std::vector<PositionAverage>& positions,
                              const FitNoiseOptions& noise_options) {
  require_positions(positions, "cannot fit (joint)");
  const InvariantData d = invariant_data(positions);
  FitResult r;
  r.estimator = "joint";
  const std::vector<std::string> reasons = unobservable_reasons(d);
  std::vector<int> fitted;
  for (int j = 0; j < kUnitParameterCount; ++j) {
    if (reasons[static_cast<std::size_t>(j)].empty())
      fitted.push_back(j);
    else
      r.unit[static_cast<std::size_t>(j)].unobservable_reason =
          reasons[static_cast<std::size_t>(j)];
  }
  if (fitted.empty())
    throw CannotFit(
        "cannot fit: " + positions_for_unknowns(positions, kUnitParameterCount) +
        "; this programme separates none of the unit's parameters (each is unobservable or "
        "only part of a combination)");
  std::vector<Eigen::Index> rows(positions.size());
  for (std::size_t k = 0; k < rows.size(); ++k) rows[k] = static_cast<Eigen::Index>(k);
  MatrixXd L = weighted_ls_map(d, rows, fitted);
  // The noise model from the white fit's residuals, then the fit again under it.
  const VectorXd white_residual = d.y - fitted_columns(d, fitted) * (L * d.y);
  const FitNoiseChoice noise =
      invariant_noise_choice(d, positions, fitted, white_residual, noise_options);
  if (!noise.noise.white()) L = gls_map(d, positions, fitted, noise.noise);
  finish_linear_fit(d, positions, L, fitted, noise.noise, r);
  r.chi2 = chi2_against(d, positions, fitted, L, noise.check_noise);  // a finding's wander only
  r.noise = noise.finding;
  widen_sigmas(d, positions, fitted, noise, r);
  r.redundancy -= noise.parameters;  // the chi-square test loses the estimated noise's dof
  r.chi2_dof = r.redundancy > 0 ? r.chi2 / r.redundancy : kNaN;
  return r;
}

FitResult fit_paper_sequential(const std::vector<PositionAverage>& positions) {
  require_positions(positions, "cannot fit (paper-sequential)");
  const InvariantData d = invariant_data(positions);
  const auto near_zero = [](double a_deg) { return std::abs(std::remainder(a_deg, 360.0)) < 1e-6; };
  std::vector<Eigen::Index> step1, step2, step3;
  for (std::size_t k = 0; k < positions.size(); ++k) {
    const PositionAverage& p = positions[k];
    if (p.mount != Mount::x)
      throw std::runtime_error("paper-sequential applies to one mounting (x); position " +
                               std::to_string(p.pos) + " is mounted " + mount_name(p.mount));
    const auto ik = static_cast<Eigen::Index>(k);
    if (near_zero(p.alpha2_cmd_deg))
      step1.push_back(ik);
    else if (near_zero(p.alpha1_cmd_deg))
      step2.push_back(ik);
    else
      step3.push_back(ik);
  }
  if (step1.size() < 5 || step2.size() < 3 || step3.empty())
    throw std::runtime_error(
        "paper-sequential needs the paper's structure: at least 5 positions at alpha2 = 0, 3 "
        "at alpha1 = 0 and 1 with both angles non-zero; this programme has " +
        std::to_string(step1.size()) + ", " + std::to_string(step2.size()) + " and " +
        std::to_string(step3.size()) + " (use --method joint)");

  // Each step fits its columns to what the earlier steps leave unexplained; tracking the
  // linear map L (x = L y) lets the covariance follow exactly.
  const std::vector<std::pair<std::vector<Eigen::Index>, std::vector<int>>> steps{
      {step1, {kBiasX, kBiasY, kScaleX, kScaleY, kGamma12}},
      {step2, {kBiasZ, kScaleZ, kGamma23}},
      {step3, {kGamma13}}};
  MatrixXd L = MatrixXd::Zero(kUnitParameterCount, d.y.size());
  std::vector<int> known;
  for (const auto& [rows, cols] : steps) {
    MatrixXd R = MatrixXd::Zero(static_cast<Eigen::Index>(rows.size()), d.y.size());
    for (std::size_t i = 0; i < rows.size(); ++i) {
      const auto ii = static_cast<Eigen::Index>(i);
      R(ii, rows[i]) = 1.0;
      for (int j : known) R.row(ii) -= d.H(rows[i], j) * L.row(j);
    }
    const MatrixXd P = weighted_ls_map(d, rows, cols);
    const MatrixXd step_map = P * R;
    for (std::size_t c = 0; c < cols.size(); ++c)
      L.row(cols[c]) = step_map.row(static_cast<Eigen::Index>(c));
    known.insert(known.end(), cols.begin(), cols.end());
  }
  FitResult r;
  r.estimator = "paper-sequential";
  std::vector<int> all(kUnitParameterCount);
  for (int j = 0; j < kUnitParameterCount; ++j) all[static_cast<std::size_t>(j)] = j;
  finish_linear_fit(d, positions, L, all, GaussMarkovNoise{}, r);
  r.noise.how =
      "white noise assumed (the paper's sequential procedure weights each mean as independent)";
  return r;
}

}  // namespace standcal
