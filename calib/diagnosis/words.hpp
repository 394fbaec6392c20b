#pragma once
// The diagnosis in sentences a bench engineer reads, with numbers.
#include <string>
#include <vector>

#include "calib/diagnosis/diagnosis.hpp"
#include "calib/diagnosis/selection.hpp"
#include "calib/fit_result.hpp"

namespace standcal::diagnosis {

// printf-style formatting of one number: fmt("%.1f", v); num(v) is signed, "+1.2".
std::string fmt(const char* f, double v);
std::string num(double v, int prec = 1);

// The unit parameter that moved most (in its own sigma) between baseline and final fit,
// e.g. "bias_z (+23.1 ug)"; empty when nothing moved by 3 sigma.
std::string absorbed_words(const FitResult& before, const FitResult& after);
// "bias_x +45.1 +- 0.9 ug, ..." for every observable unit parameter.
std::string parameters_words(const FitResult& fit);

// A chosen column term as a finding, explained.
Finding term_finding(const Chosen& c, const TermEstimate& te, const std::string& absorbed);

// Two rivals the data cannot tell apart, and whether the proposed poses would (by how many
// sigma of one dwell mean at the best), or only a different temperature profile.
std::vector<std::string> rivals_words(const Rivals& r, bool no_pose_separates,
                                      const std::vector<ProposedPosition>& proposed);

// Sentences around the findings: the baseline first, then (after what is already there)
// the verdict's words, every finding's explanation and the corrected parameters.
void summarise(Diagnosis& d, const std::string& model_words);

}  // namespace standcal::diagnosis
