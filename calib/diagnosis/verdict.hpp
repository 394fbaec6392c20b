#pragma once
// The verdict (docs/diagnosis.md step 7): consistent, explained, unexplained, ambiguous, or
// insufficient_redundancy when the programme cannot check the model at all.
#include <string>

#include "calib/diagnosis/diagnosis.hpp"
#include "calib/diagnosis/prepare.hpp"

namespace standcal::diagnosis {

// Why the model cannot be checked on this programme, in words, or empty when it can: no
// redundancy, no more distinct gravity projections than the nine unit parameters, more
// than half of the positions unpredictable from the others, or fewer than half of the
// candidates standing out from the calibration parameters.
std::string redundancy_shortfall(const Prepared& P);

// The verdict once the candidates are tested.
std::string verdict_of(const Diagnosis& d, bool ambiguous, const DiagnoseOptions& options);

}  // namespace standcal::diagnosis
