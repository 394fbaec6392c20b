#include "calib/diagnosis/selection.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <utility>

#include "calib/distributions.hpp"
#include "calib/report.hpp"
#include "calib/units.hpp"

namespace standcal::diagnosis {

using Eigen::MatrixXd;
using Eigen::VectorXd;

LinearFit empty_linear_fit(const MatrixXd& X, const VectorXd& y, int positions) {
  LinearFit f;
  f.beta = VectorXd::Zero(X.cols());
  f.cov = MatrixXd::Zero(X.cols(), X.cols());
  f.residual = y;
  f.chi2 = y.squaredNorm();
  f.dof = static_cast<int>(y.size());
  f.press = VectorXd::Constant(positions, kNaN);
  return f;
}

namespace {

// Leave-one-position-out prediction residuals from the hat matrix H, block by block.
VectorXd press_by_position(const MatrixXd& H, const VectorXd& residual,
                           const std::vector<int>& row_position, int positions) {
  VectorXd press = VectorXd::Constant(positions, kNaN);
  for (int k = 0; k < positions; ++k) {
    std::vector<Eigen::Index> rows;
    for (std::size_t r = 0; r < row_position.size(); ++r)
      if (row_position[r] == k) rows.push_back(static_cast<Eigen::Index>(r));
    const auto n = static_cast<Eigen::Index>(rows.size());
    MatrixXd M = MatrixXd::Identity(n, n);
    VectorXd e(n);
    for (Eigen::Index a = 0; a < n; ++a) {
      e[a] = residual[rows[static_cast<std::size_t>(a)]];
      for (Eigen::Index b = 0; b < n; ++b)
        M(a, b) -= H(rows[static_cast<std::size_t>(a)], rows[static_cast<std::size_t>(b)]);
    }
    Eigen::SelfAdjointEigenSolver<MatrixXd> es(M);
    if (es.eigenvalues().minCoeff() < 1e-6) continue;
    press[k] = M.ldlt().solve(e).squaredNorm();
  }
  return press;
}

VectorXd unit_norms(const MatrixXd& X) {
  VectorXd norms = X.colwise().norm().transpose();
  for (Eigen::Index j = 0; j < norms.size(); ++j)
    if (norms[j] <= 0) norms[j] = 1;
  return norms;
}

}  // namespace

LinearFit solve_linear(const MatrixXd& X, const VectorXd& y, const std::vector<int>& row_position,
                       int positions) {
  if (X.cols() == 0 || X.rows() == 0) return empty_linear_fit(X, y, positions);
  LinearFit f;
  const VectorXd norms = unit_norms(X);
  const MatrixXd Xn = X * norms.cwiseInverse().asDiagonal();
  Eigen::CompleteOrthogonalDecomposition<MatrixXd> cod(Xn);
  cod.setThreshold(1e-10);
  f.rank = static_cast<int>(cod.rank());
  const VectorXd bn = cod.solve(y);
  f.beta = bn.cwiseQuotient(norms);
  f.residual = y - Xn * bn;
  f.chi2 = f.residual.squaredNorm();
  f.dof = static_cast<int>(y.size()) - f.rank;
  const MatrixXd pinv = cod.pseudoInverse();
  const MatrixXd covn = pinv * pinv.transpose();
  f.cov = norms.cwiseInverse().asDiagonal() * covn * norms.cwiseInverse().asDiagonal();
  f.press = press_by_position(Xn * pinv, f.residual, row_position, positions);
  return f;
}

MatrixXd with_columns(const MatrixXd& A, const std::vector<VectorXd>& cols) {
  MatrixXd X(A.rows(), A.cols() + static_cast<Eigen::Index>(cols.size()));
  X.leftCols(A.cols()) = A;
  for (std::size_t j = 0; j < cols.size(); ++j)
    X.col(A.cols() + static_cast<Eigen::Index>(j)) = cols[j];
  return X;
}

double press_gain(const LinearFit& before, const LinearFit& after) {
  double gain = 0;
  for (Eigen::Index k = 0; k < before.press.size(); ++k)
    if (std::isfinite(before.press[k]) && std::isfinite(after.press[k]))
      gain += before.press[k] - after.press[k];
  return gain;
}

double consistency_p(double chi2, int dof) {
  return dof > 0 ? chi_square_upper_tail(chi2, dof) : 1.0;
}

double bic_gain(double delta_chi2, int params, std::size_t n) {
  return delta_chi2 - params * std::log(static_cast<double>(n));
}

double significance_for(double chi2_1, int params) {
  if (params <= 1) return chi2_1;
  return -2.0 * std::log(std::erfc(std::sqrt(chi2_1 / 2.0)));
}

MatrixXd unexplained_part(const MatrixXd& A, const MatrixXd& C) {
  if (A.cols() == 0 || A.rows() == 0) return C;
  const VectorXd norms = unit_norms(A);
  const MatrixXd An = A * norms.cwiseInverse().asDiagonal();
  Eigen::CompleteOrthogonalDecomposition<MatrixXd> cod(An);
  cod.setThreshold(1e-10);
  return C - An * cod.solve(C);
}

VectorXd unabsorbed_fractions(const MatrixXd& A, const MatrixXd& C) {
  return fractions_left(C, unexplained_part(A, C));
}

VectorXd fractions_left(const MatrixXd& C, const MatrixXd& rest) {
  VectorXd f(C.cols());
  for (Eigen::Index j = 0; j < C.cols(); ++j) {
    const double n = C.col(j).norm();
    f[j] = n > 0 ? rest.col(j).norm() / n : 0.0;
  }
  return f;
}

double smallest_singular_value(const MatrixXd& M) {
  return M.size() == 0 ? 0.0 : Eigen::JacobiSVD<MatrixXd>(M).singularValues().minCoeff();
}

double term_sigma(const MatrixXd& unexplained) {
  const double s = smallest_singular_value(unexplained);
  return s > 0 ? 1.0 / s : std::numeric_limits<double>::infinity();
}

TermEstimate term_estimate(const Candidate& c, const VectorXd& beta, const MatrixXd& cov,
                           Eigen::Index first, double scale) {
  if (c.params() == 1) return {beta[first], std::sqrt(cov(first, first)) * scale, 0};
  const double a = beta[first], b = beta[first + 1];
  const double amplitude = std::hypot(a, b);
  const Eigen::Matrix2d C = cov.block(first, first, 2, 2) * scale * scale;
  const double var = amplitude > 0 ? (a * a * C(0, 0) + 2 * a * b * C(0, 1) + b * b * C(1, 1)) /
                                         (amplitude * amplitude)
                                   : 0.5 * (C(0, 0) + C(1, 1));
  return {amplitude, std::sqrt(var), std::atan2(b, a) * kRadToDeg};
}

double sigma_scale(const LinearFit& f) {
  return std::max(1.0, f.dof > 0 ? std::sqrt(f.chi2 / f.dof) : 1.0);
}

CandidateTest candidate_test(const Candidate& c, const std::string& untestable_reason) {
  CandidateTest t{
      c.effect(), c.axis, c.unit(), untestable_reason.empty(), untestable_reason, 0, 0, 0, 0, 0, 0};
  t.params = c.params();
  return t;
}

std::vector<Candidate> Selection::chosen_candidates() const {
  std::vector<Candidate> out;
  for (const Chosen& c : chosen) out.push_back(c.cand);
  return out;
}

namespace {

// One candidate added to the current model: its value, sigma and the three gains.
CandidateTest test_against(const Candidate& c, CandidateTest t, const ResidualModel& model,
                           const std::vector<PositionContext>& ctx, const Selection& s) {
  const LinearProblem& lp = model.problem();
  std::vector<VectorXd> cols = s.chosen_cols;
  const MatrixXd extra = candidate_columns(c, model, ctx);
  for (Eigen::Index j = 0; j < extra.cols(); ++j) cols.push_back(extra.col(j));
  const LinearFit f = solve_linear(with_columns(lp.A, cols), lp.y, lp.row_position, lp.positions);
  if (f.rank < s.current.rank + c.params()) {
    t.testable = false;
    t.reason = "collinear with the terms already chosen";
    return t;
  }
  const TermEstimate te =
      term_estimate(c, f.beta, f.cov, f.beta.size() - c.params(), sigma_scale(f));
  if (!std::isfinite(te.value) || !std::isfinite(te.sigma)) {  // never reported with a number
    t.testable = false;
    t.reason = kNoFiniteValue;
    return t;
  }
  t.value = te.value;
  t.sigma = te.sigma;
  t.phase_deg = te.phase_deg;
  t.delta_chi2 = s.current.chi2 - f.chi2;
  t.delta_bic = bic_gain(t.delta_chi2, c.params(), static_cast<std::size_t>(lp.y.size()));
  t.press_gain = press_gain(s.current, f);
  return t;
}

bool already_chosen(const Selection& s, const Candidate& c) {
  bool already = false;
  for (const Chosen& k : s.chosen)
    already = already || (k.cand.effect() == c.effect() && k.cand.axis == c.axis);
  return already;
}

// Terms with more parameters need a larger chi2 gain for the same false-finding
// probability; candidates are ranked by their gain beyond that need.
double excess(const CandidateTest& t, const DiagnoseOptions& options) {
  return t.testable ? t.delta_chi2 - significance_for(options.significance_chi2, t.params) : -1e300;
}

using Tested = std::pair<CandidateTest, std::size_t>;  // a test and its candidate's index

// One round: every candidate not yet chosen against the current model, best first; and
// the implausible candidate that explains most (fitted, though it is listed without a
// number: an explanation the data cannot rule out still competes in the ambiguity rule).
struct Round {
  std::vector<Tested> tests;
  std::optional<Tested> implausible_best;
};

Round test_round(const ResidualModel& model, const std::vector<PositionContext>& ctx,
                 const std::vector<Candidate>& cands, const std::vector<std::string>& untestable,
                 const std::vector<bool>& implausible, const Selection& s,
                 const DiagnoseOptions& options) {
  Round r;
  for (std::size_t i = 0; i < cands.size(); ++i) {
    if (already_chosen(s, cands[i])) continue;
    const CandidateTest t = candidate_test(cands[i], untestable[i]);
    r.tests.push_back({t.testable ? test_against(cands[i], t, model, ctx, s) : t, i});
    if (!implausible[i]) continue;
    const CandidateTest fitted =
        test_against(cands[i], candidate_test(cands[i], ""), model, ctx, s);
    if (fitted.testable && (!r.implausible_best ||
                            excess(fitted, options) > excess(r.implausible_best->first, options)))
      r.implausible_best = {fitted, i};
  }
  std::stable_sort(r.tests.begin(), r.tests.end(), [&options](const Tested& a, const Tested& b) {
    return excess(a.first, options) > excess(b.first, options);
  });
  return r;
}

// The best and its nearest rival (the second best, or the implausible candidate when it
// explains more) when the data cannot tell them apart.
std::optional<Rivals> rivals_in(const Round& r, const std::vector<Candidate>& cands,
                                const std::vector<std::string>& untestable,
                                const std::vector<bool>& implausible,
                                const DiagnoseOptions& options) {
  std::optional<Tested> rival;
  if (r.tests.size() > 1) rival = r.tests[1];
  if (r.implausible_best &&
      (!rival || excess(r.implausible_best->first, options) > excess(rival->first, options)))
    rival = r.implausible_best;
  const CandidateTest& best = r.tests.front().first;
  if (!rival || !rival->first.testable || excess(rival->first, options) <= 0 ||
      excess(best, options) - excess(rival->first, options) >= options.ambiguity_chi2)
    return std::nullopt;
  CandidateTest named = rival->first;
  if (implausible[rival->second])  // named without a value
    named = candidate_test(cands[rival->second], untestable[rival->second]);
  named.delta_chi2 = rival->first.delta_chi2;
  return Rivals{best, named, cands[r.tests.front().second], cands[rival->second]};
}

// The selection with one more term.
void choose(Selection& s, const Candidate& cand, double delta_chi2, const ResidualModel& model,
            const std::vector<PositionContext>& ctx) {
  const LinearProblem& lp = model.problem();
  Chosen c;
  c.cand = cand;
  c.delta_chi2 = delta_chi2;
  c.chi2_dof_before = s.current.dof > 0 ? s.current.chi2 / s.current.dof : kNaN;
  const MatrixXd cols = candidate_columns(c.cand, model, ctx);
  for (Eigen::Index j = 0; j < cols.cols(); ++j) s.chosen_cols.push_back(cols.col(j));
  s.current = solve_linear(with_columns(lp.A, s.chosen_cols), lp.y, lp.row_position, lp.positions);
  c.chi2_dof_after = s.current.dof > 0 ? s.current.chi2 / s.current.dof : kNaN;
  s.chosen.push_back(c);
}

}  // namespace

Selection forward_selection(const ResidualModel& model, const std::vector<PositionContext>& ctx,
                            const std::vector<Candidate>& cands,
                            const std::vector<std::string>& untestable,
                            const std::vector<bool>& implausible, const LinearFit& base,
                            const DiagnoseOptions& options) {
  Selection s;
  s.current = base;
  for (int round = 0; round < options.max_terms; ++round) {
    const Round r = test_round(model, ctx, cands, untestable, implausible, s, options);
    if (round == 0)
      for (const Tested& t : r.tests) s.first_round.push_back(t.first);
    if (r.tests.empty()) break;
    const CandidateTest& best = r.tests.front().first;
    if (!(best.testable && excess(best, options) > 0 && best.delta_bic > 0 && best.press_gain > 0))
      break;  // nothing significant is left
    s.rivals = rivals_in(r, cands, untestable, implausible, options);
    if (s.rivals) break;
    choose(s, cands[r.tests.front().second], best.delta_chi2, model, ctx);
  }
  return s;
}

}  // namespace standcal::diagnosis
