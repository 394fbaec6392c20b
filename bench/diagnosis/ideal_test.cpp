#include "bench/diagnosis/ideal_test.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>

#include "calib/averaging.hpp"
#include "calib/full_estimator.hpp"

namespace standcal::bench {

namespace {

// The catalog terms are probed at this size (report unit): large enough that the
// Levenberg-Marquardt baseline converges far below the leftover, small enough that the
// baseline's rotations stay linear (tens of ug).
constexpr double kProbeSize = 10;

GeneratorTruth effect_only(const std::vector<ConcealedEffect>& effects,
                           const ChamberProfile& chamber) {
  GeneratorTruth t;
  t.chamber = chamber;
  t.effects = effects;
  return noise_free(t);
}

// Per-position averages of a noise-free recording, each given the noisy recording's
// standard error (a noise-free mean would otherwise weigh nothing or everything).
std::vector<PositionAverage> with_errors_of(std::vector<PositionAverage> clean,
                                            const std::vector<PositionAverage>& noisy) {
  if (clean.size() != noisy.size())
    throw std::invalid_argument("ideal test: the recordings are not of one run");
  for (std::size_t k = 0; k < clean.size(); ++k)
    clean[k].standard_error_g = noisy[k].standard_error_g;
  return clean;
}

Eigen::VectorXd whitened_residuals(const FitResult& fit) {
  Eigen::VectorXd r(3 * static_cast<Eigen::Index>(fit.residuals.size()));
  for (std::size_t k = 0; k < fit.residuals.size(); ++k)
    r.segment<3>(3 * static_cast<Eigen::Index>(k)) =
        fit.residuals[k].residual_g.cwiseQuotient(fit.residuals[k].sigma_g);
  return r;
}

// Sum over samples of (sample - its dwell mean)^2 / sample sigma^2, per axis.
double within_dwell_chi2(const Recording& clean, const std::vector<PositionAverage>& noisy) {
  double chi2 = 0;
  std::size_t first = 0, block = 0;
  for (std::size_t i = 1; i <= clean.samples.size(); ++i) {
    if (i < clean.samples.size() && clean.samples[i].pos == clean.samples[first].pos) continue;
    Vec3 mean = Vec3::Zero();
    for (std::size_t k = first; k < i; ++k) mean += clean.samples[k].f_mps2;
    mean /= static_cast<double>(i - first);
    const Vec3 sigma_mps2 = noisy.at(block).sigma_g * clean.g_local_mps2;
    for (std::size_t k = first; k < i; ++k)
      chi2 += (clean.samples[k].f_mps2 - mean).cwiseQuotient(sigma_mps2).squaredNorm();
    first = i;
    ++block;
  }
  return chi2;
}

// What [competitor] cannot explain of C: C minus its least-squares projection.
Eigen::MatrixXd unexplained_part(const Eigen::MatrixXd& competitor, const Eigen::MatrixXd& C) {
  if (competitor.cols() == 0) return C;
  return C - competitor * competitor.completeOrthogonalDecomposition().solve(C);
}

double smallest_singular_value(const Eigen::MatrixXd& M) {
  return Eigen::JacobiSVD<Eigen::MatrixXd>(M).singularValues().minCoeff();
}

Eigen::MatrixXd probe_columns(const ConcealedEffect& probe, const ChamberProfile& chamber,
                              const GeneratorRun& run, const std::vector<PositionAverage>& noisy) {
  if (probe.id != "angle_sensor_error")
    return baseline_leftover({probe}, chamber, run, noisy) / kProbeSize;
  Eigen::MatrixXd cols(3 * static_cast<Eigen::Index>(noisy.size()), 2);
  for (int c = 0; c < 2; ++c) {
    ConcealedEffect phased = probe;
    phased.phase_deg = 90.0 * c;  // sin(alpha) and cos(alpha)
    cols.col(c) = baseline_leftover({phased}, chamber, run, noisy) / kProbeSize;
  }
  return cols;
}

}  // namespace

double chi2_tail(double x, int dof) {
  if (dof < 1) throw std::invalid_argument("chi2_tail: dof must be >= 1");
  if (!(x > 0)) return 1.0;
  const double y = x / 2;
  // Q(a + 1, y) = Q(a, y) + y^a e^-y / Gamma(a + 1), from Q(1/2, y) = erfc(sqrt y) or Q(1, y) =
  // e^-y.
  double a = dof % 2 == 1 ? 0.5 : 1.0;
  double q = dof % 2 == 1 ? std::erfc(std::sqrt(y)) : std::exp(-y);
  for (; 2 * a < dof; a += 1) q += std::exp(a * std::log(y) - y - std::lgamma(a + 1));
  return std::min(q, 1.0);
}

double noncentral_chi2_tail(double x, int dof, double lambda) {
  if (!(lambda > 0)) return chi2_tail(x, dof);
  if (!(x > 0)) return 1.0;
  const double mu = lambda / 2, y = x / 2;
  // Poisson weights beyond mu + 12 sqrt(mu) + 40 add less than 1e-30.
  const int last = static_cast<int>(mu + 12 * std::sqrt(mu) + 40);
  double tail = 0, q = chi2_tail(x, dof), a = dof / 2.0;
  for (int j = 0; j <= last; ++j, a += 1) {
    tail += std::exp(-mu + j * std::log(mu) - std::lgamma(j + 1.0)) * q;
    q += std::exp(a * std::log(y) - y - std::lgamma(a + 1));  // chi2 tail of dof + 2(j + 1)
  }
  return std::min(tail, 1.0);
}

double critical_chi2(int params, double one_parameter_chi2) {
  const double p = chi2_tail(one_parameter_chi2, 1);
  double lo = 0, hi = one_parameter_chi2 + 20.0 * params;
  for (int it = 0; it < 200; ++it) {
    const double mid = 0.5 * (lo + hi);
    (chi2_tail(mid, params) > p ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

Eigen::VectorXd baseline_leftover(const std::vector<ConcealedEffect>& effects,
                                  const ChamberProfile& chamber, const GeneratorRun& run,
                                  const std::vector<PositionAverage>& noisy) {
  const Recording clean = generate_recording(effect_only(effects, chamber), run, 0);
  return whitened_residuals(  // white, as the diagnosis's baseline (its noise comes with the terms)
      fit_full_vector(with_errors_of(average_positions(clean), noisy), white_noise_weighting()));
}

double ideal_noncentrality(const GeneratorTruth& truth, const GeneratorRun& run,
                           const std::vector<PositionAverage>& noisy) {
  GeneratorTruth t = effect_only(truth.effects, truth.chamber);
  t.g_local_mps2 = truth.g_local_mps2;
  const Recording clean = generate_recording(t, run, 0);
  const double means =
      fit_full_vector(with_errors_of(average_positions(clean), noisy), white_noise_weighting())
          .chi2;
  return means + within_dwell_chi2(clean, noisy);
}

std::vector<TermLeftover> catalog_leftovers(const ChamberProfile& chamber, const GeneratorRun& run,
                                            const std::vector<PositionAverage>& noisy) {
  std::vector<TermLeftover> out;
  for (const EffectSpec& spec : effect_specs()) {
    if (spec.kind != EffectKind::catalog || spec.id == "settling_transient" ||
        spec.id == "mounting_misalignment_large")
      continue;
    for (const std::string& axis : spec.axes)
      out.push_back(
          {spec.id, axis, probe_columns({spec.id, axis, kProbeSize}, chamber, run, noisy)});
  }
  return out;
}

double leftover_threshold(const TermLeftover& term, const std::vector<TermLeftover>& catalog,
                          std::string& nearest) {
  double smallest = smallest_singular_value(term.columns);
  nearest = "noise";
  for (const TermLeftover& k : catalog) {
    if (k.id == term.id && k.axis == term.axis) continue;
    const double s = smallest_singular_value(unexplained_part(k.columns, term.columns));
    if (s < smallest) {
      smallest = s;
      nearest = k.id + " " + k.axis;
    }
  }
  return smallest > 0 ? 3 / smallest : std::numeric_limits<double>::infinity();
}

double unexplained_norm(const Eigen::VectorXd& r, const std::vector<TermLeftover>& catalog) {
  Eigen::Index cols = 0;
  for (const TermLeftover& k : catalog) cols += k.columns.cols();
  Eigen::MatrixXd all(r.size(), cols);
  cols = 0;
  for (const TermLeftover& k : catalog) {
    all.middleCols(cols, k.columns.cols()) = k.columns;
    cols += k.columns.cols();
  }
  return unexplained_part(all, r).norm();
}

}  // namespace standcal::bench
