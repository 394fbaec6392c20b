#include "calib/diagnosis/honesty.hpp"

#include <algorithm>
#include <cmath>

#include "calib/diagnosis/residual_checks.hpp"
#include "calib/diagnosis/words.hpp"
#include "calib/text.hpp"

namespace standcal::diagnosis {

using Eigen::MatrixXd;
using Eigen::VectorXd;

namespace {

std::vector<ResidualSample> residual_samples(const Prepared& P, const VectorXd& residual) {
  const LinearProblem& lp = P.model->problem();
  std::vector<ResidualSample> out;
  for (std::size_t r = 0; r < lp.row_position.size(); ++r) {
    const auto k = static_cast<std::size_t>(lp.row_position[r]);
    const PositionContext& c = P.ctx[k];
    out.push_back({static_cast<int>(k), P.avg[k].pos, P.model->component_name(lp.row_component[r]),
                   c.t_mid_h * 3600, c.alpha1_deg, c.alpha2_deg, c.up,
                   residual[static_cast<Eigen::Index>(r)]});
  }
  return out;
}

WhitenessResult whiteness_of(const Prepared& P, const VectorXd& residual,
                             const DiagnoseOptions& options) {
  return whiteness_tests(residual_samples(P, residual), options.whiteness_family_alpha);
}

int column_rank(const MatrixXd& M) {
  if (M.cols() == 0 || M.rows() == 0) return 0;
  VectorXd norms = M.colwise().norm().transpose();
  for (Eigen::Index j = 0; j < norms.size(); ++j)
    if (norms[j] <= 0) norms[j] = 1;
  Eigen::ColPivHouseholderQR<MatrixXd> qr(M * norms.cwiseInverse().asDiagonal());
  qr.setThreshold(1e-10);
  return static_cast<int>(qr.rank());
}

// The fit of the baseline plus the chosen terms to the positions of one half of the run,
// decorrelated under the problem's noise among themselves. `terms_identifiable` is false
// when the half cannot tell the terms from the baseline (its estimates then say nothing).
struct HalfFit {
  LinearFit fit;
  bool terms_identifiable = false;
};

// Position k's half: by time for a programme, alternate intervals for a unit placed by
// hand (a hand's orientations drift with time, so time halves would see different poses).
bool in_first_half(const Prepared& P, std::size_t k, bool alternate, double t_split_h) {
  return alternate ? k % 2 == 0 : P.ctx[k].t_mid_h < t_split_h;
}

HalfFit fit_half(const Prepared& P, const MatrixXd& X_white, bool first_half, bool alternate,
                 double t_split_h) {
  const LinearProblem& lp = P.model->problem();
  std::vector<Eigen::Index> rows;
  std::vector<int> row_position;
  std::vector<NoiseRow> noise_rows;
  std::vector<int> compact(static_cast<std::size_t>(lp.positions), -1);
  int positions = 0;
  for (std::size_t r = 0; r < lp.row_position.size(); ++r) {
    const auto k = static_cast<std::size_t>(lp.row_position[r]);
    if (in_first_half(P, k, alternate, t_split_h) != first_half) continue;
    if (compact[k] < 0) compact[k] = positions++;
    rows.push_back(static_cast<Eigen::Index>(r));
    row_position.push_back(compact[k]);
    noise_rows.push_back(lp.noise_rows[r]);
  }
  HalfFit out;
  if (rows.empty()) return out;
  const MatrixXd X = decorrelate(noise_rows, lp.noise, X_white(rows, Eigen::all));
  const VectorXd y = decorrelate(noise_rows, lp.noise, lp.y_white(rows));
  const Eigen::Index baseline_cols = lp.A.cols();
  out.fit = solve_linear(X, y, row_position, positions);
  out.terms_identifiable =
      out.fit.dof > 0 && column_rank(X) - column_rank(X.leftCols(baseline_cols)) ==
                             static_cast<int>(X.cols() - baseline_cols);
  return out;
}

double median_time_h(const Prepared& P) {
  std::vector<double> t;
  for (const PositionContext& c : P.ctx) t.push_back(c.t_mid_h);
  std::nth_element(t.begin(), t.begin() + static_cast<std::ptrdiff_t>(t.size() / 2), t.end());
  return t[t.size() / 2];
}

std::vector<StabilityCheck> stability_checks(const Prepared& P, const Selection& s,
                                             const DiagnoseOptions& options) {
  std::vector<StabilityCheck> out;
  if (s.chosen.empty()) return out;
  const LinearProblem& lp = P.model->problem();
  const MatrixXd X =
      with_columns(lp.A_white, term_columns_white(*P.model, P.ctx, s.chosen_candidates()));
  const double t_split_h = median_time_h(P);
  const bool alternate = options.attitude_free;
  const HalfFit halves[2] = {fit_half(P, X, true, alternate, t_split_h),
                             fit_half(P, X, false, alternate, t_split_h)};
  Eigen::Index col = lp.A.cols();
  for (const Chosen& c : s.chosen) {
    const TermEstimate whole =
        term_estimate(c.cand, s.current.beta, s.current.cov, col, sigma_scale(s.current));
    TermEstimate half[2];
    for (int h = 0; h < 2; ++h) {
      const LinearFit& f = halves[h].fit;
      half[h] = halves[h].terms_identifiable
                    ? term_estimate(c.cand, f.beta, f.cov, col, sigma_scale(f))
                    : TermEstimate{kNaN, kNaN, 0};
    }
    HalfStability hs{
        c.cand.effect(), c.cand.axis,   c.cand.unit(), whole.value, whole.sigma, half[0].value,
        half[0].sigma,   half[1].value, half[1].sigma, 0,           true};
    judge_half_stability(hs, options.half_stability_z);
    out.push_back({hs.effect, hs.axis, hs.unit, hs.value_all, hs.sigma_all,
                   alternate ? "alternate" : "time", hs.value_first, hs.sigma_first,
                   hs.value_second, hs.sigma_second, hs.z, hs.stable});
    col += c.cand.params();
  }
  return out;
}

std::vector<std::string> implausible_values(const std::vector<Finding>& findings,
                                            const DiagnoseOptions& options) {
  std::vector<std::string> out;
  for (const Finding& f : findings) {
    const double bound = options.implausible_factor * catalog_entry(f.effect).typical_max *
                         options.plausible_size_factor;
    if (std::abs(f.value) <= bound) continue;
    // Both at the decimals that show the value past the bound (not "+500.0 is beyond 500").
    const auto [size, beyond] = fixed_texts_apart(f.value, bound, 1);
    out.push_back(f.effect + " " + f.axis + " " + (f.value > 0 ? "+" : "") + size + " " + f.unit +
                  " is beyond " + beyond + " " + f.unit +
                  (options.plausible_size_factor == 1
                       ? ", ten times the largest a navigation-grade unit on a good stand shows"
                       : ", ten times the largest a unit of this grade shows"));
  }
  return out;
}

// The candidates that were tried: the chosen terms, then the first round's best others.
std::vector<std::string> tried_candidates(const Selection& s) {
  std::vector<std::string> out;
  for (const Chosen& c : s.chosen) out.push_back(c.cand.effect() + " " + c.cand.axis + " (chosen)");
  if (s.rivals) {
    out.push_back(s.rivals->best.effect + " " + s.rivals->best.axis);
    out.push_back(s.rivals->rival.effect + " " + s.rivals->rival.axis);
  }
  for (const CandidateTest& t : s.first_round) {
    if (out.size() >= 4) break;
    const std::string name = t.effect + " " + t.axis;
    const bool listed = std::any_of(out.begin(), out.end(),
                                    [&](const std::string& o) { return o.rfind(name, 0) == 0; });
    if (t.testable && !listed && std::isfinite(t.delta_chi2) && t.delta_chi2 > 0)
      out.push_back(name + " (chi2 gain " + fmt("%.1f", t.delta_chi2) + ")");
  }
  return out;
}

WhitenessCheck as_check(const WhitenessTest& t) {
  return {t.component, t.against, t.test, t.statistic, t.p, t.positions, t.t_from_s, t.t_to_s};
}

}  // namespace

HonestyChecks honesty_checks(const Prepared& P, const Selection& s,
                             const std::vector<Finding>& findings, const DiagnoseOptions& options) {
  HonestyChecks c;
  c.made = true;
  c.family_alpha = options.whiteness_family_alpha;
  const WhitenessResult w = whiteness_of(P, s.current.residual, options);
  for (const WhitenessTest& t : w.tests) c.whiteness.push_back(as_check(t));
  c.worst = w.worst;
  c.stability = stability_checks(P, s, options);
  c.implausible = implausible_values(findings, options);
  const bool stable = std::all_of(c.stability.begin(), c.stability.end(),
                                  [](const StabilityCheck& k) { return k.stable; });
  c.passed = w.white && stable && c.implausible.empty();
  if (!c.passed) c.not_explaining = tried_candidates(s);
  return c;
}

bool best_rival_explains(const Prepared& P, const Selection& s, const DiagnoseOptions& options) {
  if (!s.rivals) return true;
  const LinearProblem& lp = P.model->problem();
  std::vector<VectorXd> cols = s.chosen_cols;
  const MatrixXd extra = candidate_columns(s.rivals->best_cand, *P.model, P.ctx);
  for (Eigen::Index j = 0; j < extra.cols(); ++j) cols.push_back(extra.col(j));
  const LinearFit f = solve_linear(with_columns(lp.A, cols), lp.y, lp.row_position, lp.positions);
  return consistency_p(f.chi2, f.dof) > options.consistency_p &&
         whiteness_of(P, f.residual, options).white;
}

std::vector<std::string> honesty_words(const HonestyChecks& c) {
  std::vector<std::string> out;
  if (!c.made || c.passed) return out;
  std::string s = "Not explained:";
  bool first = true;
  auto add = [&](const std::string& part) {
    s += (first ? " " : "; ") + part;
    first = false;
  };
  if (c.worst >= 0) {
    const WhitenessCheck& w = c.whiteness[static_cast<std::size_t>(c.worst)];
    if (w.p < c.family_alpha / static_cast<double>(c.whiteness.size())) {
      WhitenessTest t{w.axis, w.against,   w.test,     0,       w.statistic,
                      w.p,    w.positions, w.t_from_s, w.t_to_s};
      add(whiteness_words(t));
    }
  }
  for (const StabilityCheck& k : c.stability)
    if (!k.stable)
      add(k.effect + " " + k.axis + " is " + num(k.value) + " +- " + fmt("%.1f", k.sigma) + " " +
          k.unit + " on the whole run but " + num(k.first) + " +- " + fmt("%.1f", k.first_sigma) +
          (k.halves == "alternate" ? " on its even intervals and " : " on its first half and ") +
          num(k.second) + " +- " + fmt("%.1f", k.second_sigma) +
          (k.halves == "alternate" ? " on its odd ones (" : " on its second (") +
          fmt("%.1f", std::abs(k.z)) + " sigma apart): it fits, but it is not the physics");
  for (const std::string& i : c.implausible) add(i);
  s += ".";
  out.push_back(s);
  if (!c.not_explaining.empty()) {
    std::string n = "Catalog candidates tried that do not explain it:";
    for (std::size_t i = 0; i < c.not_explaining.size(); ++i)
      n += (i ? ", " : " ") + c.not_explaining[i];
    out.push_back(
        n +
        ". The physics is in no catalog of this tool: look at the located positions and times.");
  }
  return out;
}

}  // namespace standcal::diagnosis
