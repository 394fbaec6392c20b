#pragma once
// Checks before `explained` or `consistent` (issue 15, docs/diagnosis.md): what the chosen
// terms leave must be noise (residual_checks.hpp), every chosen term must say the same on
// each half of the run, and no found value may be implausible for its kind. When a check
// fails the mismatch is located and the catalog candidates that were tried are named as
// not explaining it.
#include <vector>

#include "calib/diagnosis/diagnosis.hpp"
#include "calib/diagnosis/prepare.hpp"
#include "calib/diagnosis/selection.hpp"

namespace standcal::diagnosis {

// The checks of the model the selection ended with, under the problem's noise.
HonestyChecks honesty_checks(const Prepared& P, const Selection& s,
                             const std::vector<Finding>& findings, const DiagnoseOptions& options);

// Two rivals the data cannot tell apart: does the better one, added to the chosen terms,
// leave noise (chi2 and whiteness)? If not, neither explains the data and the verdict is
// `unexplained`, not `ambiguous`.
bool best_rival_explains(const Prepared& P, const Selection& s, const DiagnoseOptions& options);

// The failed checks in sentences (empty when they passed).
std::vector<std::string> honesty_words(const HonestyChecks& c);

}  // namespace standcal::diagnosis
