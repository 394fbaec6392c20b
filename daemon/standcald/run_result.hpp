#pragma once
// The result of a finished run (result.json, what run.result returns): the paper's joint
// fit of the run's recording with the full-vector fit beside it, the GUM budget when one
// is configured, the compensation an INS loads (written beside it) and the run's
// traceability. No hardware and no sequencer state: the recording file and the run record
// are all it reads.
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "calib/noise_model.hpp"
#include "calib/uncertainty_budget.hpp"
#include "daemon/standcald/run_store.hpp"

namespace standcal::daemon {

// Fits `record`'s recording and returns its result document; sets `record.ended_utc` (the
// result's time) and writes the compensation files into `run_dir` first, so that a result
// that names a compensation has it on disk. The unit's wander the fits weigh with is the one
// the recording's header says the run was made with (unit.bias_instability_* when it started,
// what every later fit of the recording takes too); for a recording whose header has none (one
// begun before headers carried it), `configured`; neither, the one its own long dwell pins. A
// programme that cannot determine the unit by itself still gets a result: it says why there
// are no parameters.
nlohmann::json fit_finished_run(RunRecord& record, const std::string& run_dir,
                                const GivenWander& configured,
                                const std::optional<BudgetConfig>& budget);

}  // namespace standcal::daemon
