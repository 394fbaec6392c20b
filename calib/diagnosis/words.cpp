#include "calib/diagnosis/words.hpp"

#include "calib/diagnosis/honesty.hpp"
#include "calib/diagnosis/wander.hpp"

#include <cmath>
#include <cstdio>

#include "calib/parameters.hpp"

namespace standcal::diagnosis {

std::string fmt(const char* f, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}

std::string num(double v, int prec) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%+.*f", prec, v);
  return buf;
}

std::string absorbed_words(const FitResult& before, const FitResult& after) {
  int best = -1;
  double best_z = 3;  // below 3 sigma nothing was visibly absorbed
  for (int i = 0; i < kUnitParameterCount; ++i) {
    const auto& b = before.unit[static_cast<std::size_t>(i)];
    const auto& a = after.unit[static_cast<std::size_t>(i)];
    if (!b.value || !a.value || !a.sigma || *a.sigma <= 0) continue;
    const double z = std::abs(*b.value - *a.value) / *a.sigma;
    if (z > best_z) {
      best_z = z;
      best = i;
    }
  }
  if (best < 0) return "";
  const auto k = static_cast<std::size_t>(best);
  const double delta = (*before.unit[k].value - *after.unit[k].value) * report_scale(best);
  return std::string(kUnitParameterNames[k]) + " (" + num(delta) + " " +
         std::string(kUnitParameterUnits[k]) + ")";
}

std::string parameters_words(const FitResult& fit) {
  std::string s;
  for (int i = 0; i < kUnitParameterCount; ++i) {
    const auto& p = fit.unit[static_cast<std::size_t>(i)];
    if (!p.value) continue;
    if (!s.empty()) s += ", ";
    s += std::string(kUnitParameterNames[static_cast<std::size_t>(i)]) + " " +
         num(*p.value * report_scale(i)) + " +- " +
         fmt("%.1f", p.sigma.value_or(0) * report_scale(i)) + " " +
         std::string(kUnitParameterUnits[static_cast<std::size_t>(i)]);
  }
  return s;
}

namespace {

// Whose residuals show the term: an accelerometer, or for a stand-side term the
// horizontal components.
std::string residuals_of(const Candidate& c) {
  if (c.entry->axes == CatalogAxes::stand_axis || c.entry->axes == CatalogAxes::level_axis)
    return "the horizontal components";
  return "the " + c.axis.substr(0, 1) + " accelerometer";
}

}  // namespace

Finding term_finding(const Chosen& c, const TermEstimate& te, const std::string& absorbed) {
  Finding f{c.cand.effect(), c.cand.axis,       c.cand.unit(),    te.value, te.sigma, 0,
            c.delta_chi2,    c.chi2_dof_before, c.chi2_dof_after, absorbed, "",       te.phase_deg};
  f.explanation = "Residuals of " + residuals_of(c.cand) + " " + signature_words(f.effect, f.axis) +
                  " (chi2/dof " + fmt("%.2f", f.chi2_dof_before) + " -> " +
                  fmt("%.2f", f.chi2_dof_after) +
                  "). Missing physics: " + effect_words(f.effect, f.axis) + ", " + num(f.value) +
                  " +- " + fmt("%.1f", f.sigma) + " " + f.unit;
  if (c.cand.entry->parametrisation == Parametrisation::cyclic)
    f.explanation += " amplitude (true angle = reading + amplitude * sin(" + f.axis + " " +
                     num(f.phase_deg) + " deg))";
  f.explanation += ".";
  if (!f.absorbed_into.empty())
    f.explanation += " It had been absorbed into " + f.absorbed_into + ".";
  return f;
}

namespace {

// What the proposed poses achieve: one dwell at the best tells the rivals apart at 3 sigma,
// or it does not and they need repeating.
std::string proposals_words(const std::vector<ProposedPosition>& proposed) {
  if (proposed.empty()) return "";
  const double best = proposed.front().predicted_difference_sigma;
  if (best >= 3) return " The proposed positions tell them apart.";
  return " The proposed positions separate them best, yet by only " + fmt("%.1f", best) +
         " sigma of one dwell mean: repeat them or dwell longer there.";
}

// A rival with its value, or, when no plausible size of it is testable, without one.
std::string rival_words(const CandidateTest& t) {
  const std::string gain = "chi2 gain " + fmt("%.1f", t.delta_chi2);
  if (!t.testable)
    return effect_words(t.effect, t.axis) + " (at an implausible size, " + gain + ")";
  return effect_words(t.effect, t.axis) + " (" + num(t.value) + " " + t.unit + ", " + gain + ")";
}

}  // namespace

std::vector<std::string> rivals_words(const Rivals& r, bool no_pose_separates,
                                      const std::vector<ProposedPosition>& proposed) {
  std::vector<std::string> s;
  if (no_pose_separates)
    s.push_back(
        "No stand position tells these two apart (they differ in time or temperature, not in "
        "angle); a run whose temperature is not a straight line in time (hold, then ramp) would.");
  s.push_back("Two explanations fit about equally well: " + rival_words(r.best) + " and " +
              rival_words(r.rival) + "." + proposals_words(proposed));
  return s;
}

void summarise(Diagnosis& d, const std::string& model_words) {
  d.summary.insert(d.summary.begin(), "Baseline (" + model_words + ") fit: chi2/dof " +
                                          fmt("%.2f", d.baseline.chi2_dof) +
                                          ", P = " + fmt("%.3g", d.baseline_p) + ".");
  if (const std::string n = noise_words(d.noise); !n.empty()) d.summary.push_back(n);
  if (d.verdict == "consistent")
    d.summary.push_back(
        "The residuals are consistent with noise and no catalog candidate improves both the fit "
        "and the held-out prediction: no missing physics found.");
  for (const Finding& f : d.findings) d.summary.push_back(f.explanation);
  if (!d.findings.empty())
    d.summary.push_back("Corrected parameters: " + parameters_words(d.final_fit) +
                        ". Final chi2/dof " + fmt("%.2f", d.final_chi2_dof) +
                        " (P = " + fmt("%.3g", d.final_p) + ").");
  const std::vector<std::string> not_explained = honesty_words(d.checks);
  d.summary.insert(d.summary.end(), not_explained.begin(), not_explained.end());
  if (d.verdict == "unexplained" && not_explained.empty())
    d.summary.push_back(
        "The residuals are not consistent with noise and the catalog does not explain all of it.");
}

}  // namespace standcal::diagnosis
