#pragma once
// Term selection on a residual model (docs/diagnosis.md steps 4-5): weighted least squares
// on the whitened problem with candidate columns added, the leave-one-position-out check,
// BIC, and forward selection with the ambiguity rule.
#include <Eigen/Dense>
#include <optional>
#include <string>
#include <vector>

#include "calib/diagnosis/catalog.hpp"
#include "calib/diagnosis/diagnosis.hpp"
#include "calib/diagnosis/position_context.hpp"
#include "calib/diagnosis/residual_model.hpp"

namespace standcal::diagnosis {

// Weighted least squares on whitened data with columns scaled to unit norm (the design
// mixes 1/sigma ~ 1e6 with candidate columns ~ 1; scaling keeps the rank decision sane).
struct LinearFit {
  Eigen::VectorXd beta;      // in the original column units
  Eigen::MatrixXd cov;       // of beta
  Eigen::VectorXd residual;  // whitened
  double chi2 = 0;
  int rank = 0;
  int dof = 0;
  Eigen::VectorXd press;  // per position, NaN where it cannot be predicted without itself
};

// No column (nothing fitted) or no row: the residual is the data itself. Eigen's
// decompositions must never see an empty matrix (a zero-column QR segfaulted; issue 14).
LinearFit empty_linear_fit(const Eigen::MatrixXd& X, const Eigen::VectorXd& y, int positions);
LinearFit solve_linear(const Eigen::MatrixXd& X, const Eigen::VectorXd& y,
                       const std::vector<int>& row_position, int positions);
// The model's design with extra columns.
Eigen::MatrixXd with_columns(const Eigen::MatrixXd& A, const std::vector<Eigen::VectorXd>& cols);

// Held-out chi2 gain of `after` over `before`, over positions both can predict.
double press_gain(const LinearFit& before, const LinearFit& after);
// P(chi2 > observed) for dof degrees of freedom (1 when there are none).
double consistency_p(double chi2, int dof);
double bic_gain(double delta_chi2, int params, std::size_t n);
// The chi2 gain a k-parameter term needs for the same false-finding probability as a
// one-parameter term at chi2_1 (P(chi2_2 > t) = exp(-t/2) for two).
double significance_for(double chi2_1, int params);

// The part of C's columns that the columns of A cannot explain (least squares on A with
// unit-norm columns). With no column in A nothing is explained: an empty QR must never run.
Eigen::MatrixXd unexplained_part(const Eigen::MatrixXd& A, const Eigen::MatrixXd& C);
// Fractions of each column (of C) the baseline design A cannot absorb.
Eigen::VectorXd unabsorbed_fractions(const Eigen::MatrixXd& A, const Eigen::MatrixXd& C);
// The same from C's unexplained part (unexplained_part(A, C)).
Eigen::VectorXd fractions_left(const Eigen::MatrixXd& C, const Eigen::MatrixXd& unexplained);

// A term stands out when it is this many sigma from zero (discrimination thresholds).
inline constexpr double kStandOut_sigma = 3;
// The smallest singular value of M (0 for an empty M).
double smallest_singular_value(const Eigen::MatrixXd& M);
// The sigma (its columns' unit) of a term under white noise, from the part of its whitened
// columns that what is fitted besides cannot explain: 1 / s_min (for one column
// 1 / |P c|). Infinite when nothing is left.
double term_sigma(const Eigen::MatrixXd& unexplained);

// A term's value and sigma in its report unit; cyclic terms (a sin + b cos) are reported as
// amplitude and phase.
struct TermEstimate {
  double value = 0, sigma = 0, phase_deg = 0;
};
TermEstimate term_estimate(const Candidate& c, const Eigen::VectorXd& beta,
                           const Eigen::MatrixXd& cov, Eigen::Index first, double scale);
// sqrt(chi2/dof) of a fit, at least 1: sigmas are widened when the residuals are not noise.
double sigma_scale(const LinearFit& f);

// Why a candidate whose fitted value or sigma is not a finite number is not testable.
inline constexpr const char* kNoFiniteValue =
    "the fit gives no finite value for it on this programme";

// A candidate as listed before any fit: testable unless `untestable_reason` says why not.
CandidateTest candidate_test(const Candidate& c, const std::string& untestable_reason);

struct Chosen {
  Candidate cand;
  double delta_chi2 = 0;
  double chi2_dof_before = 0, chi2_dof_after = 0;
};

// Two candidates the data cannot tell apart: selection stops there and claims neither. The
// rival may be one not testable at a plausible size (rival.testable false, no value).
struct Rivals {
  CandidateTest best, rival;
  Candidate best_cand, rival_cand;
};

struct Selection {
  std::vector<CandidateTest> first_round;  // every candidate against the baseline, best first
  std::vector<Chosen> chosen;
  std::vector<Eigen::VectorXd> chosen_cols;  // their whitened columns, in order
  LinearFit current;                         // the baseline with the chosen terms
  std::optional<Rivals> rivals;

  std::vector<Candidate> chosen_candidates() const;
};

// Forward selection: each round tests every candidate against the current model; a term
// is kept when its chi2 gain beats significance_for, BIC improves and the held-out
// prediction improves. `untestable[i]` is empty for a testable candidate; `implausible[i]`
// marks one not testable only because no plausible size would stand out: it is never kept,
// but when it explains about as well as the best (or better) the two are rivals.
Selection forward_selection(const ResidualModel& model, const std::vector<PositionContext>& ctx,
                            const std::vector<Candidate>& cands,
                            const std::vector<std::string>& untestable,
                            const std::vector<bool>& implausible, const LinearFit& base,
                            const DiagnoseOptions& options);

}  // namespace standcal::diagnosis
