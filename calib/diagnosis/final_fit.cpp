#include "calib/diagnosis/final_fit.hpp"

#include <cmath>
#include <numeric>

#include "calib/units.hpp"

namespace standcal::diagnosis {

namespace {

// Unit sigmas from the augmented fit: they carry the correlation with the new terms.
void take_augmented_sigmas(FitResult& fit, const LinearProblem& lp, const LinearFit& augmented) {
  const double scale = sigma_scale(augmented);
  for (int i = 0; i < kUnitParameterCount; ++i) {
    const int col = lp.unit_column[static_cast<std::size_t>(i)];
    if (col >= 0 && fit.unit[static_cast<std::size_t>(i)].value)
      fit.unit[static_cast<std::size_t>(i)].sigma = std::sqrt(augmented.cov(col, col)) * scale;
  }
}

// A settling transient's uncertainty moves the bias it had been aliased into.
void widen_bias_sigmas(FitResult& fit, const std::vector<SettlingResult>& settling) {
  for (const SettlingResult& st : settling) {
    auto& bias = fit.unit[static_cast<std::size_t>(st.axis)];
    if (!bias.value || !bias.sigma) continue;
    const double shape = std::accumulate(st.mean_shape.begin(), st.mean_shape.end(), 0.0) /
                         static_cast<double>(st.mean_shape.size());
    bias.sigma = std::hypot(*bias.sigma, st.sigma_ug * kUg * shape);
  }
}

// The refit's chi2 under the noise the terms were tested against: its own (weighted least
// squares) under white noise; under bias wander the generalised least-squares minimum of
// its linearisation, so that wander the noise model carries is not counted as misfit.
double chi2_under_noise(ResidualModel& refitted, const GaussMarkovNoise& noise) {
  if (noise.white()) return refitted.fit().chi2;
  refitted.use_noise(noise);
  const LinearProblem& lp = refitted.problem();
  return solve_linear(lp.A, lp.y, lp.row_position, lp.positions).chi2;
}

}  // namespace

FinalFit final_fit(const Prepared& P, const Selection& selection,
                   const std::vector<SettlingResult>& settling) {
  const LinearProblem& lp = P.model->problem();
  const LinearFit& current = selection.current;
  FinalFit out;
  std::vector<PositionAverage> corrected = P.avg;
  int n_term_params = 0;
  Eigen::Index col = lp.A.cols();
  for (const Chosen& c : selection.chosen) {
    out.terms.push_back(
        term_estimate(c.cand, current.beta, current.cov, col, sigma_scale(current)));
    const Eigen::VectorXd beta = current.beta.segment(col, c.cand.params());
    for (std::size_t k = 0; k < corrected.size(); ++k)
      corrected[k].mean_g -= candidate_effect_g(c.cand, P.ctx[k]) * beta;
    col += c.cand.params();
    n_term_params += c.cand.params();
  }
  remove_settling(corrected, settling);
  out.model = P.model->refit(corrected);
  out.fit = out.model->fit();
  const int final_dof = out.fit.redundancy - n_term_params;
  const double chi2 = chi2_under_noise(*out.model, lp.noise);
  out.chi2_dof = final_dof > 0 ? chi2 / final_dof : kNaN;
  out.p = consistency_p(chi2, final_dof);
  if (!selection.chosen.empty()) {
    take_augmented_sigmas(out.fit, lp, current);
    out.fit.redundancy = final_dof;
    out.fit.chi2_dof = out.chi2_dof;
  }
  widen_bias_sigmas(out.fit, settling);
  return out;
}

}  // namespace standcal::diagnosis
