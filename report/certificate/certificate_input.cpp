// prepare_certificate(): from a run folder (or a recording) to everything the page shows.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>

#include "calib/averaging.hpp"
#include "calib/diagnosis/diagnosis.hpp"
#include "calib/full_estimator.hpp"
#include "calib/invariant_estimator.hpp"
#include "calib/recording.hpp"
#include "calib/report.hpp"
#include "calib/text.hpp"
#include "calib/utc_time.hpp"
#include "report/certificate/certificate.hpp"
#include "standcal/version.hpp"

namespace standcal::report {

namespace {

namespace fs = std::filesystem;
using nlohmann::json;

json read_json_file(const fs::path& path, const char* what) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path.string() + ": cannot open the " + what);
  std::stringstream text;
  text << in.rdbuf();
  try {
    return json::parse(text.str());
  } catch (const json::parse_error& e) {
    throw std::runtime_error(path.string() + ": the " + what + " is not valid JSON (" + e.what() +
                             ")");
  }
}

std::string string_key(const json& j, const char* key) {
  return j.contains(key) && j[key].is_string() ? j[key].get<std::string>() : std::string();
}

struct LoadedRun {
  CertificateTraceability trace;
  Recording recording;
  fs::path run_dir;  // empty for an offline recording
  std::string unit_type_hint;
};

// The daemon's run record (docs/daemon.md): traceability, then the recording beside it.
LoadedRun load_state_run(const CertificateRequest& req) {
  LoadedRun run;
  // One plain name under STATE/runs: a run id never leads out of the state directory.
  const fs::path id(req.run_id);
  if (req.run_id.find('/') != std::string::npos || id == "." || id == "..")
    throw std::runtime_error("'" + req.run_id + "' is not a run id: a run id names a folder in " +
                             req.state_dir + "/runs, it is not a path");
  run.run_dir = fs::path(req.state_dir) / "runs" / req.run_id;
  const fs::path record_path = run.run_dir / "run.json";
  if (!fs::exists(record_path))
    throw std::runtime_error("no run " + req.run_id + " in " + req.state_dir + " (" +
                             record_path.string() +
                             " does not exist; `standcal run list` shows the runs)");
  const json record = read_json_file(record_path, "run record");
  const std::string state = string_key(record, "state");
  if (state != "done")
    throw std::runtime_error("run " + req.run_id + " is '" + state +
                             "', not done: only a finished run gets a " +
                             "certificate (certify its recording with --recording to override)");
  CertificateTraceability& t = run.trace;
  t.origin = "standcald run record (" + record_path.string() + ")";
  t.run_id = req.run_id;
  t.unit_serial = string_key(record, "unit_serial");
  t.stand_id = string_key(record, "stand_id");
  t.operator_name = string_key(record, "operator");
  t.started_utc = string_key(record, "started_utc");
  t.ended_utc = string_key(record, "ended_utc");
  t.software_version = string_key(record, "software_version");
  t.config_hash = string_key(record, "config_hash");
  t.g_source = string_key(record, "g_source");
  run.unit_type_hint = string_key(record, "unit_type");
  // The folder may have been moved since the run: prefer the recording beside run.json.
  fs::path recording = run.run_dir / "recording.csv";
  if (!fs::exists(recording) && !string_key(record, "recording_path").empty())
    recording = string_key(record, "recording_path");
  t.recording_path = recording.string();
  run.recording = read_recording(t.recording_path);
  t.g_local_mps2 = run.recording.g_local_mps2;
  if (record.contains("g_local_mps2") && record["g_local_mps2"].is_number() &&
      std::abs(record["g_local_mps2"].get<double>() - t.g_local_mps2) > 1e-9)
    run.recording.warnings.push_back("run.json says g = " + record["g_local_mps2"].dump() +
                                     " m/s^2 but the recording header says " +
                                     round_trip_text(t.g_local_mps2) +
                                     "; the recording's value was used");
  return run;
}

// An imported or offline recording: what its header says is all the traceability there is.
LoadedRun load_recording_only(const CertificateRequest& req) {
  LoadedRun run;
  run.recording = read_recording(req.recording_path);
  const Recording& rec = run.recording;
  CertificateTraceability& t = run.trace;
  t.origin = "imported recording (no run record)";
  t.recording_path = req.recording_path;
  t.run_id = rec.header_value("run_id");
  t.unit_serial = rec.unit_serial;
  t.stand_id = rec.header_value("stand_id");
  t.operator_name = rec.header_value("operator");
  t.started_utc = rec.header_value("started_utc");
  t.software_version = rec.header_value("software_version");
  t.config_hash = rec.header_value("config_hash");
  t.g_source = rec.header_value("g_source");
  t.g_local_mps2 = rec.g_local_mps2;
  run.unit_type_hint = rec.header_value("unit_type");
  return run;
}

void note_missing_traceability(CertificateInput& in) {
  const CertificateTraceability& t = in.trace;
  const std::pair<const char*, const std::string*> fields[] = {
      {"unit serial", &t.unit_serial},
      {"stand id", &t.stand_id},
      {"operator", &t.operator_name},
      {"date", &t.started_utc},
      {"software version", &t.software_version},
      {"configuration hash", &t.config_hash},
      {"source of g", &t.g_source}};
  for (const auto& [name, value] : fields)
    if (value->empty())
      in.warnings.push_back(std::string("the ") + name + " is not recorded for this calibration");
}

}  // namespace

CertificateDiagnosis certificate_diagnosis_from_json(const json& doc, const std::string& origin) {
  if (!doc.is_object() || !doc.contains("verdict") || !doc["verdict"].is_string())
    throw std::runtime_error(origin +
                             ": verdict: missing (not a `standcal diagnose --json` document)");
  CertificateDiagnosis d;
  d.origin = origin;
  d.verdict = doc["verdict"].get<std::string>();
  for (const char* key : {"summary", "located"}) {
    if (!doc.contains(key)) continue;
    if (!doc[key].is_array())
      throw std::runtime_error(origin + ": " + key + ": must be a list of sentences");
    auto& into = std::string(key) == "summary" ? d.summary : d.located;
    for (const json& s : doc[key])
      if (s.is_string()) into.push_back(s.get<std::string>());
  }
  return d;
}

CertificateInput prepare_certificate(const CertificateRequest& req) {
  if (req.run_id.empty() == req.recording_path.empty())
    throw std::runtime_error(
        "give either a RUN_ID (with --state-dir) or --recording FILE, not both or neither");
  if (req.method != "joint" && req.method != "full")
    throw std::runtime_error("unknown method '" + req.method + "' (joint, full)");
  LoadedRun run = req.run_id.empty() ? load_recording_only(req) : load_state_run(req);

  CertificateInput in;
  in.trace = run.trace;
  in.trace.unit_type = req.unit_type.empty() ? run.unit_type_hint : req.unit_type;
  in.program_name = run.recording.program;
  in.warnings = run.recording.warnings;
  AveragedRecording averaged = average_recording(run.recording);
  if (!averaged.allan_warning.empty()) in.warnings.push_back(averaged.allan_warning);
  in.positions = std::move(averaged.averages);
  in.issued_utc = utc_now_iso();
  in.issuing_software_version = kVersion;
  if (!req.lab_path.empty()) in.lab = load_lab_identity(req.lab_path);
  in.certificate_number =
      !req.certificate_number.empty()
          ? req.certificate_number
          : default_certificate_number(in.lab ? in.lab->certificate_prefix : "SC", in.issued_utc,
                                       in.trace.unit_serial);

  // Nothing of the unit's wander given: the header's, else the one the unit's static recording
  // pins, else the one the recording's own long dwell pins (as `standcal fit`).
  FitNoiseOptions noise = req.noise;
  std::optional<UnitStaticAllan> static_allan;
  if (req.unit_static_recording)
    static_allan = stand_unit_static_allan(*req.unit_static_recording, run.recording.g_local_mps2);
  in.unit_static_recording = take_unit_wander_with_static_recording(
      noise, run.recording, averaged.allan, static_allan ? &*static_allan : nullptr);
  if (in.unit_static_recording) {
    const std::vector<std::string>& w = in.unit_static_recording->warnings;
    in.warnings.insert(in.warnings.end(), w.begin(), w.end());
  } else if (may_take_recording_wander(req.noise)) {
    // The run's, where nothing of the certificate's own overrode the header's wander.
    in.run_unit_static_recording = run_unit_static_recording_words(run.recording);
  }
  in.invariant = fit_invariant_joint(in.positions, noise);
  in.invariant->noise.allan = averaged.allan;
  try {
    FullFitOptions full;
    full.noise = noise;
    in.full = fit_full_vector(in.positions, full);
    in.full->noise.allan = averaged.allan;
  } catch (const std::exception& e) {
    in.warnings.push_back(std::string("no per-axis residuals: the full-vector fit failed (") +
                          e.what() + ")");
  }
  if (req.method == "full" && !in.full)
    throw std::runtime_error("--method full: the full-vector fit failed");
  in.fit = req.method == "full" ? *in.full : *in.invariant;
  if (in.unit_static_recording) settle_unit_static_use(*in.unit_static_recording, in.fit.noise);
  in.compensation = make_compensation(in.fit, in.trace.g_local_mps2);
  const CertificateTraceability& t = in.trace;
  in.compensation.identity =
      compensation_identity(RunIdentity{t.unit_serial, t.unit_type, t.run_id, t.stand_id,
                                        t.ended_utc, t.recording_path, t.g_source},
                            in.positions);

  std::optional<records::LimitsConfig> limits;
  if (!req.limits_path.empty()) {
    limits = records::load_limits(req.limits_path);
    in.trace.unit_type = limits->for_unit_type(in.trace.unit_type).unit_type;
    in.coverage_factor = limits->coverage_factor;
  }
  if (!req.budget_path.empty()) {
    in.budget = evaluate_budget(in.positions, in.fit, budget_estimator(req.method, in.fit),
                                load_budget_config(req.budget_path), in.trace.unit_type,
                                in.trace.g_local_mps2);
  }
  if (limits && in.budget && limits->coverage_factor != records::kDefaultCoverageFactor) {
    in.warnings.push_back("the limits file's coverage_factor " +
                          round_trip_text(limits->coverage_factor) +
                          " is not used: with the uncertainty budget, U is the 95 % expanded "
                          "uncertainty, k from each "
                          "parameter's effective degrees of freedom");
  }
  if (limits) {
    in.conformity = records::assess_conformity(in.fit, limits->for_unit_type(in.trace.unit_type),
                                               limits->coverage_factor, req.limits_path,
                                               in.budget ? &*in.budget : nullptr);
  }

  const fs::path stored_diagnosis =
      run.run_dir.empty() ? fs::path() : run.run_dir / "diagnosis.json";
  if (req.diagnose) {
    // The unit's wander as the operator gave it to the fits; none: the header's or the long
    // dwell's, as the fits'. (The diagnosis models the noise itself, even under --noise white.)
    DiagnoseOptions options;
    options.specified_wander = req.noise.specified;
    options.known_tau = req.noise.known_tau;
    if (in.unit_static_recording && in.unit_static_recording->gave == "wander")
      options.give_static_recording_wander(in.unit_static_recording->wander);
    // Where it pins none, the floor its curves put under the correlation time (0: none), before
    // the header's, as the fits take it.
    else if (static_allan)
      options.unit_static_tau_floor_s = static_allan->allan.wander_tau_floor_s;
    const Diagnosis d = diagnose_recording(run.recording, options);
    in.diagnosis =
        CertificateDiagnosis{d.verdict, d.summary, d.located, "run for this certificate"};
  } else if (!stored_diagnosis.empty() && fs::exists(stored_diagnosis)) {
    in.diagnosis = certificate_diagnosis_from_json(read_json_file(stored_diagnosis, "diagnosis"),
                                                   stored_diagnosis.string());
  }
  note_missing_traceability(in);
  return in;
}

}  // namespace standcal::report
