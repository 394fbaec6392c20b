#include "daemon/standcald/run_result.hpp"

#include "calib/allan.hpp"
#include "calib/compensation.hpp"
#include "calib/full_estimator.hpp"
#include "calib/identifiability.hpp"
#include "calib/invariant_estimator.hpp"
#include "calib/norm_calibration.hpp"
#include "calib/recording_digest.hpp"
#include "calib/report.hpp"
#include "calib/utc_time.hpp"

namespace standcal::daemon {

using nlohmann::json;

namespace {

// The paper's joint fit of a finished run. A programme that cannot determine the unit by
// itself (a follow-up of proposed positions, a user programme of a few poses) still ends
// `done`: its recording is whole, and the result says why there are no parameters (and
// there is no compensation).
struct JointFit {
  json result;
  std::optional<FitResult> fit;
};

JointFit joint_fit(const std::vector<PositionAverage>& averages, const FitNoiseOptions& noise,
                   const std::optional<AllanFinding>& allan) {
  try {
    FitResult fit = fit_invariant_joint(averages, noise);
    fit.noise.allan = allan;
    return {fit_to_json(fit), std::move(fit)};
  } catch (const CannotFit& e) {
    return {json{{"estimator", "joint"},
                 {"positions", averages.size()},
                 {"parameters", json::object()},
                 {"fit_error", e.what()}},
            std::nullopt};
  }
}

// The GUM budget of the run's joint fit with the configured inputs (run.budget). A budget
// that cannot be evaluated says why in the result; the run is done all the same.
json run_budget(const FitResult& fit, const RunRecord& record,
                const std::vector<PositionAverage>& averages, const BudgetConfig& config) {
  try {
    return budget_to_json(evaluate_budget(averages, fit, budget_estimator("joint", fit), config,
                                          record.unit_type, record.g_local_mps2));
  } catch (const std::exception& e) {
    return json{{"error", e.what()}};
  }
}

// The compensation of the run's joint fit, with the run's identity: what an INS loads.
Compensation run_compensation(const FitResult& fit, const RunRecord& record,
                              const std::vector<PositionAverage>& averages) {
  Compensation c = make_compensation(fit, record.g_local_mps2);
  c.identity = compensation_identity(
      RunIdentity{record.unit_serial, record.unit_type, record.run_id, record.stand_id,
                  record.ended_utc, record.recording_path, record.g_source},
      averages);
  stamp_written(c);
  return c;
}

}  // namespace

json fit_finished_run(RunRecord& record, const std::string& run_dir, const GivenWander& configured,
                      const std::optional<BudgetConfig>& budget) {
  // Streamed: the daemon holds one dwell of the recording, not the whole run.
  const RecordingDigest digest = digest_recording(record.recording_path);
  const std::vector<PositionAverage>& averages = digest.averages;
  // The noise model of both fits: wander between dwells from the fit, Allan within them.
  const std::optional<AllanFinding> allan = digest.allan_finding();
  // The unit's configured wander, as the header keeps it (a correlation time configured: the
  // run then estimates only the wander's size, which one run pins far better than tau); none
  // configured: the one the recording's own long dwell pins (a warm-up), if any, else what the
  // unit's static recording's curves give (the header carries them): the bound they set where
  // they show none, or the floor they put under the correlation time where they see one they
  // do not pin; and the recording's own long dwell's bound or floor. As every later fit of the
  // recording weighs.
  FitNoiseOptions noise;
  const Recording& rec = digest.recording;
  if (header_silent_on_unit_wander(rec)) configured.give_to(noise);  // a run begun before
  take_unit_wander_with_static_recording(noise, rec, allan, nullptr);
  JointFit joint = joint_fit(averages, noise, allan);
  json& result = joint.result;
  try {
    FullFitOptions full_options;
    full_options.noise = noise;
    FitResult full = fit_full_vector(averages, full_options);
    full.noise.allan = allan;
    result["full_vector"] = fit_to_json(full);
  } catch (const std::exception& e) {
    result["full_vector"] = json{{"error", e.what()}};
  }
  record.ended_utc = utc_now_iso();
  result["recording_path"] = record.recording_path;
  result["traceability"] = traceability_to_json(record);
  put_unit_wander_source(result, digest.recording);  // what its unit.static_recording gave
  result["recording_warnings"] = digest.recording.warnings;
  if (std::string why = digest.allan_warning(); !why.empty())
    result["recording_warnings"].push_back(std::move(why));
  if (joint.fit && budget)
    result["uncertainty_budget"] = run_budget(*joint.fit, record, averages, *budget);
  if (joint.fit) {
    // The files first: a result that names a compensation has it on disk.
    const Compensation c = run_compensation(*joint.fit, record, averages);
    write_compensation(c, run_dir + "/compensation", 0640);
    result["compensation"] = compensation_to_json(c);
  }
  return result;
}

}  // namespace standcal::daemon
