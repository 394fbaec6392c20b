// diagnose_recording (diagnosis.hpp): the method of docs/diagnosis.md, step by step.
#include <algorithm>
#include <string>
#include <vector>

#include "calib/diagnosis/catalog.hpp"
#include "calib/diagnosis/consistency.hpp"
#include "calib/diagnosis/diagnosis.hpp"
#include "calib/diagnosis/final_fit.hpp"
#include "calib/diagnosis/honesty.hpp"
#include "calib/diagnosis/json.hpp"
#include "calib/diagnosis/mounting.hpp"
#include "calib/diagnosis/prepare.hpp"
#include "calib/diagnosis/proposals.hpp"
#include "calib/diagnosis/selection.hpp"
#include "calib/diagnosis/settling.hpp"
#include "calib/diagnosis/verdict.hpp"
#include "calib/diagnosis/wander.hpp"
#include "calib/diagnosis/words.hpp"

namespace standcal {

namespace diagnosis {

namespace {

const CatalogEntry& large_mounting_entry() { return catalog_entry("mounting_misalignment_large"); }

// Catalog ids the residual model or the recording cannot test at all, with why.
std::vector<std::string> not_tested_words(const ResidualModel& model, bool have_temp) {
  std::vector<std::string> out;
  if (!model.sees(large_mounting_entry())) out.push_back(mounting_not_tested_words());
  if (!have_temp) {
    std::string ids;
    for (const CatalogEntry& e : catalog())
      if (e.needs_temperature) ids += (ids.empty() ? "" : ", ") + std::string(e.id);
    out.push_back(ids + ": the recording has no temperature column");
  }
  return out;
}

// insufficient_redundancy: the programme cannot check the model; propose positions that would.
Diagnosis cannot_check(Diagnosis d, const Prepared& P, const std::string& why,
                       const DiagnoseOptions& options) {
  d.verdict = "insufficient_redundancy";
  d.final_fit = d.baseline;
  d.final_p = d.baseline_p;
  d.final_chi2_dof = d.baseline.chi2_dof;
  d.proposed_positions =
      propose_for_redundancy(*P.model, P.ctx, P.cands, P.avg.front().mount, options.limits);
  d.summary.push_back("The model cannot be checked on this programme: " + why +
                      ". Add the proposed positions and run again.");
  for (std::size_t i = 0; i < P.cands.size(); ++i)
    d.candidates.push_back(candidate_test(P.cands[i], P.untestable[i]));
  d.residuals = residual_table(P.avg, P.ctx, P.model->problem(), P.model->problem());
  d.model = TruthModel{};
  return d;
}

// Two rivals the data cannot tell apart: the poses that would, or why none does.
void explain_rivals(Diagnosis& d, const Prepared& P, const Selection& s,
                    const DiagnoseOptions& options) {
  const Discrimination found =
      propose_discriminating(*P.model, P.ctx, s, *s.rivals, P.avg.front().mount, options.limits);
  d.proposed_positions = found.positions;
  for (const std::string& w : rivals_words(*s.rivals, found.no_pose_separates, found.positions))
    d.summary.push_back(w);
}

// Every finding, most significant first: chosen terms, settling transients, large mountings.
std::vector<Finding> findings_of(const Diagnosis& d, const Selection& s, const FinalFit& refitted,
                                 const std::vector<SettlingResult>& settling,
                                 const std::vector<CandidateTest>& mounting,
                                 const DiagnoseOptions& options) {
  std::vector<Finding> out;
  const std::string absorbed = absorbed_words(d.baseline, d.final_fit);
  for (std::size_t j = 0; j < s.chosen.size(); ++j)
    out.push_back(term_finding(s.chosen[j], refitted.terms[j], j == 0 ? absorbed : ""));
  for (const SettlingResult& st : settling) out.push_back(settling_finding(st));
  const MountingEstimate m = mounting_estimate(d.final_fit);
  for (const CandidateTest& t : mounting)
    if (t.testable && t.delta_chi2 > options.significance_chi2)
      out.push_back(mounting_finding(t, m, d.final_chi2_dof, options));
  std::stable_sort(out.begin(), out.end(),
                   [](const Finding& a, const Finding& b) { return a.delta_chi2 > b.delta_chi2; });
  return out;
}

bool has_large_mounting(const Diagnosis& d) {
  return std::any_of(d.findings.begin(), d.findings.end(),
                     [](const Finding& f) { return f.effect == large_mounting_entry().id; });
}

// `explained` and `consistent` only when what is left is noise (honesty.hpp); `ambiguous`
// only when the better rival would leave noise. Otherwise `unexplained`, located.
std::string checked_verdict(Diagnosis& d, const Prepared& P, const Selection& s,
                            const DiagnoseOptions& options) {
  if (d.verdict != "explained" && d.verdict != "consistent") return d.verdict;
  if (s.rivals) {  // rivals that would not leave noise: neither explains the data
    d.checks = honesty_checks(P, s, d.findings, options);
    d.checks.passed = false;
    return "unexplained";
  }
  d.checks = honesty_checks(P, s, d.findings, options);
  return d.checks.passed ? d.verdict : "unexplained";
}

}  // namespace

}  // namespace diagnosis

Diagnosis diagnose_recording(const Recording& rec, const DiagnoseOptions& given) {
  using namespace diagnosis;
  Diagnosis d;
  d.source = rec.source;
  // 1. Baseline: position averages, the residual model's fit, linearised.
  Prepared P = prepare(rec, given);
  // Nothing of the unit's wander given: the one its header says the run was made with, else the
  // one the recording's own long dwell pins, else the higher floor under its correlation time
  // that the unit's static recording and that dwell put, which the fits of the same recording
  // weigh with (take_unit_wander).
  const DiagnoseOptions options = with_unit_wander(given, rec, P.allan);
  if (options.known_tau && options.known_tau->open_above) {
    d.tau_floor_from = options.specified_wander_from;
    d.tau_floor_outcome = "untested";  // until the terms and noise are chosen
  }
  const ResidualModel& model = *P.model;
  d.method = model.name();
  d.baseline = model.fit();
  // 2-3. Consistency, structure and location of the baseline's residuals.
  d.baseline_p = consistency_p(P.base.chi2, P.base.dof);
  d.structure = structure_tests(model, P.ctx, P.have_temp);
  d.located = locate(model, P.avg);
  d.not_tested = not_tested_words(model, P.have_temp);
  if (const std::string why = redundancy_shortfall(P); !why.empty())
    return cannot_check(std::move(d), P, why, options);
  // 4-5. Candidates, forward selection, ambiguity; the noise they are tested against.
  const NoiseAndTerms chosen = select_terms_and_noise(P, options);
  const Selection& selection = chosen.selection;
  // Kept, the wander was a finding under the floor; it is no longer one where the class bound
  // refused it as noise.
  if (!d.tau_floor_from.empty())
    d.tau_floor_outcome = chosen.tau_floor_set_aside ? "set_aside"
                          : chosen.noise.significant ? "kept"
                                                     : "refused";
  d.noise = noise_finding(chosen.noise, P.avg,
                          chosen.tau_floor_set_aside ? std::nullopt : options.known_tau);
  if (chosen.weighted_as_specified) d.noise.source = "specified";  // a finding, tested as given
  d.noise.unit_wander_given = !options.specified_wander.white();
  if (d.noise.unit_wander_given) d.noise.unit_wander_from = options.specified_wander_from;
  d.baseline_p = consistency_p(P.base.chi2, P.base.dof);
  d.candidates = selection.first_round;
  // Two rivals are only worth telling apart when the better one would leave noise.
  const bool rivals_explain = selection.rivals && best_rival_explains(P, selection, options);
  if (rivals_explain) explain_rivals(d, P, selection, options);
  // 6. Settling transients, on the raw samples.
  const std::vector<SettlingResult> settling = settling_findings(rec, P.avg, options, d.candidates);
  // Final fit on the averages corrected by what was found.
  const FinalFit refitted = final_fit(P, selection, settling);
  d.final_fit = refitted.fit;
  d.final_chi2_dof = refitted.chi2_dof;
  d.final_p = refitted.p;
  // Large mounting misalignment: the size of the final fit's mounting angles.
  std::vector<CandidateTest> mounting;
  if (model.sees(catalog_entry("mounting_misalignment_large")))
    mounting = mounting_tests(d.final_fit, d.final_chi2_dof,
                              static_cast<std::size_t>(model.problem().y.size()), options);
  d.candidates.insert(d.candidates.end(), mounting.begin(), mounting.end());
  // 7. Findings; the checks before saying they (or nothing) explain the data; the verdict.
  d.findings = findings_of(d, selection, refitted, settling, mounting, options);
  d.verdict = verdict_of(d, rivals_explain, options);
  d.verdict = checked_verdict(d, P, selection, options);
  d.residuals = residual_table(P.avg, P.ctx, model.problem(), refitted.model->problem());
  summarise(d, model.words());
  // 8. The augmented model.
  const MountingEstimate fitted_mounting = mounting_estimate(d.final_fit);
  d.model = augmented_model(d, rec, P, has_large_mounting(d) ? &fitted_mounting : nullptr);
  return d;
}

}  // namespace standcal
