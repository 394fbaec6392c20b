#pragma once
// The yardstick for the diagnosis's detection power (issue 15, item 6): the ideal
// likelihood-ratio test, which knows the concealed term's shape and tests only it against
// the calibration baseline. Its statistic is non-central chi2 with `params` degrees of
// freedom and non-centrality lambda = the chi2 the baseline leaves of the effect alone
// (noise-free) against the noise of the real recording; its power at the diagnosis's
// critical value is what no test can beat.
//
// Also what the baseline leaves of each catalog term, made with the effect generator (not
// with the diagnosis's own columns): for thresholds of terms the diagnosis does not know
// yet, and to check that an "uncatalogued" effect really is no combination of catalog terms.
#include <Eigen/Dense>
#include <string>
#include <vector>

#include "bench/diagnosis/effect_generator.hpp"
#include "calib/position_average.hpp"

namespace standcal::bench {

// P(chi2_dof > x) for an integer dof >= 1, exact: the regularised upper incomplete gamma
// Q(dof/2, x/2) by its recursion from erfc (odd dof) or exp (even dof).
double chi2_tail(double x, int dof);
// P(chi2_dof(lambda) > x): the Poisson mixture sum_j Pois(j; lambda/2) P(chi2_{dof+2j} > x).
double noncentral_chi2_tail(double x, int dof, double lambda);
// The chi2 a `params`-parameter term must beat to have the false-finding probability that
// `one_parameter_chi2` has for one parameter (the diagnosis: 16 -> 19.3 for two).
double critical_chi2(int params, double one_parameter_chi2);

// The whitened residuals (residual / standard error; 3 per position) the full-vector baseline
// (fit_full_vector on the per-position averages) leaves of the noise-free recording of
// `effects` alone (no unit or stand errors), each position's standard error set to the one of
// `noisy`, averages of a recording of the same run.
Eigen::VectorXd baseline_leftover(const std::vector<ConcealedEffect>& effects,
                                  const ChamberProfile& chamber, const GeneratorRun& run,
                                  const std::vector<PositionAverage>& noisy);

// Non-centrality of the ideal test on the raw samples: the baseline's leftover of the
// effect-only per-position means plus, inside each dwell, the effect's deviation from its
// dwell mean against the noisy sample sigma (where a settling transient shows).
double ideal_noncentrality(const GeneratorTruth& truth, const GeneratorRun& run,
                           const std::vector<PositionAverage>& noisy);

// One catalog term's leftover per report unit: one column, or two for the angle-sensor
// error (sine and cosine parts, phases 0 and 90 deg).
struct TermLeftover {
  std::string id, axis;
  Eigen::MatrixXd columns;
};
// Every catalog term a per-position model can show (all but the settling transient, which
// only the raw samples show, and the large mounting, a baseline parameter).
std::vector<TermLeftover> catalog_leftovers(const ChamberProfile& chamber, const GeneratorRun& run,
                                            const std::vector<PositionAverage>& noisy);

// The discrimination threshold of model.md's definition computed from generator-made
// leftovers: 3 / min over competitors k of s_min(P_perp[k] C). `nearest` names k.
double leftover_threshold(const TermLeftover& term, const std::vector<TermLeftover>& catalog,
                          std::string& nearest);
// The part of r that no combination of all catalog terms explains, as a norm (its square is
// the chi2 the best combination leaves when r is a whitened leftover).
double unexplained_norm(const Eigen::VectorXd& r, const std::vector<TermLeftover>& catalog);

}  // namespace standcal::bench
