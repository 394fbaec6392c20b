#pragma once
// The diagnosis as data: diagnose_to_json (diagnosis.hpp) and the augmented model in
// standcal-model/1 that `standcal simulate --model` reproduces the recording from.
#include "calib/diagnosis/diagnosis.hpp"
#include "calib/diagnosis/mounting.hpp"
#include "calib/diagnosis/prepare.hpp"

namespace standcal::diagnosis {

// The corrected unit parameters (gamma as symmetric pair sums), a white-noise density from
// the dwell sigmas, the recording's temperature start and rate, the findings as
// extra_physics, and the fitted mounting when it is a finding (null: not a finding).
TruthModel augmented_model(const Diagnosis& d, const Recording& rec, const Prepared& P,
                           const MountingEstimate* large_mounting);

}  // namespace standcal::diagnosis
