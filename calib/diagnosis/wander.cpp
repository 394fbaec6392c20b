#include "calib/diagnosis/wander.hpp"

#include <algorithm>
#include <cmath>

#include "calib/diagnosis/words.hpp"
#include "calib/units.hpp"

namespace standcal::diagnosis {

namespace {

constexpr int kMaxAlternations = 3;

NoiseEstimate wander_with_terms(const ResidualModel& model, const std::vector<PositionContext>& ctx,
                                const Selection& s, const DiagnoseOptions& options) {
  const LinearProblem& lp = model.problem();
  std::vector<Eigen::VectorXd> cols;
  for (const Chosen& c : s.chosen) {
    const Eigen::MatrixXd m = candidate_columns(c.cand, model, ctx, /*white_only=*/true);
    for (Eigen::Index j = 0; j < m.cols(); ++j) cols.push_back(m.col(j));
  }
  NoiseEstimateOptions o;
  o.lr_threshold = options.wander_lr_threshold;
  return estimate_bias_wander(lp.noise_rows, with_columns(lp.A_white, cols), lp.y_white, o);
}

bool same_terms(const Selection& a, const Selection& b) {
  if (a.chosen.size() != b.chosen.size()) return false;
  for (std::size_t i = 0; i < a.chosen.size(); ++i)
    if (a.chosen[i].cand.effect() != b.chosen[i].cand.effect() || a.chosen[i].cand.axis != b.chosen[i].cand.axis)
      return false;
  return a.rivals.has_value() == b.rivals.has_value();
}

Selection select_under(Prepared& P, const GaussMarkovNoise& noise, const DiagnoseOptions& options) {
  P.model->use_noise(noise);
  const LinearProblem& lp = P.model->problem();
  P.base = solve_linear(lp.A, lp.y, lp.row_position, lp.positions);
  return forward_selection(*P.model, P.ctx, P.cands, P.untestable, P.base, options);
}

}  // namespace

NoiseAndTerms select_terms_and_noise(Prepared& P, const DiagnoseOptions& options) {
  NoiseAndTerms out;
  // Start from white noise: a deterministic effect in the data is then found as a term
  // before the wander estimate could take it for noise.
  out.selection = select_under(P, GaussMarkovNoise{}, options);
  for (int i = 0; i < kMaxAlternations; ++i) {
    NoiseEstimate again = wander_with_terms(*P.model, P.ctx, out.selection, options);
    const bool noise_changed = again.significant != out.noise.significant;
    out.noise = std::move(again);
    if (!noise_changed && i > 0) break;
    if (!out.noise.significant && i == 0) break;  // white it was and white it stays
    Selection next = select_under(P, out.noise.noise, options);
    const bool stable = same_terms(next, out.selection);
    out.selection = std::move(next);
    if (stable) break;
  }
  return out;
}

NoiseFinding noise_finding(const NoiseEstimate& e, const std::vector<PositionAverage>& avg) {
  NoiseFinding n;
  n.lr = e.lr;
  n.lr_threshold = e.lr_threshold;
  n.how = e.how;
  if (!e.significant) return n;
  n.model = "gauss_markov";
  n.bias_instability = true;
  n.tau_s = e.noise.tau_s;
  for (int a = 0; a < 3; ++a) {
    std::vector<double> se;
    for (const PositionAverage& p : avg) se.push_back(p.standard_error_g[a]);
    std::nth_element(se.begin(), se.begin() + static_cast<std::ptrdiff_t>(se.size() / 2), se.end());
    const double sigma = se[se.size() / 2], q = e.noise.q_g[a];
    n.wander_ug[a] = q / kUg;
    n.allan_peak_ug[a] = gauss_markov_allan_peak(q, e.noise.tau_s).deviation / kUg;
    n.understated_by[a] = sigma > 0 ? std::sqrt(1 + q * q / (sigma * sigma)) : 1.0;
  }
  return n;
}

std::string noise_words(const NoiseFinding& n) {
  if (!n.bias_instability) return "";
  std::string s = "Noise: the dwell means wander more than their white-noise errors allow (bias instability, a noise "
                  "finding, not missing physics): Gauss-Markov";
  for (int a = 0; a < 3; ++a)
    s += std::string(a ? "," : "") + " " + kAxisNames[a] + " " + fmt("%.1f", n.wander_ug[a]) + " ug";
  s += ", correlation time " + fmt("%.0f", n.tau_s) + " s (Allan floor";
  for (int a = 0; a < 3; ++a) s += std::string(a ? "," : "") + " " + fmt("%.1f", n.allan_peak_ug[a]);
  s += " ug); sigma/sqrt(n) understated a dwell mean's error by up to " +
       fmt("%.1f", n.understated_by.maxCoeff()) + "x. Every test above weighs the positions with this noise "
       "(generalised least squares; 2 delta log L = " + fmt("%.0f", n.lr) + ").";
  return s;
}

}  // namespace standcal::diagnosis
