#pragma once
// The calibration certificate (issue 8): one self-contained HTML page (inline SVG plots,
// no external files) that a newcomer can read without knowing the software — who, what,
// where, with what traceability; each parameter as value ± U (k = 2) with its pass/fail
// and margin under the stated decision rule; the compensation to load; residual plots per
// position and axis; and the diagnosis verdict when one was run. Contents: docs/certificate.md.
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "calib/compensation.hpp"
#include "calib/fit_result.hpp"
#include "calib/norm_calibration.hpp"
#include "calib/position_average.hpp"
#include "calib/report.hpp"
#include "calib/traceability.hpp"
#include "calib/uncertainty_budget.hpp"
#include "records/limits/limits.hpp"
#include "report/certificate/lab_identity.hpp"

namespace standcal::report {

struct CertificateTraceability : Traceability {
  CertificateTraceability() { g_local_mps2 = kStandardGravity_mps2; }
  std::string recording_path;
  std::string origin;  // "standcald run record" or "imported recording"
};

// A model-mismatch diagnosis (calib/diagnosis/diagnosis.hpp), reduced to what a certificate
// shows.
struct CertificateDiagnosis {
  std::string
      verdict;  // consistent | explained | unexplained | insufficient_redundancy | ambiguous
  std::vector<std::string> summary;
  std::vector<std::string> located;
  std::string origin;  // "run for this certificate" or the diagnosis.json path
};

struct CertificateInput {
  CertificateTraceability trace;
  std::string program_name;
  std::vector<PositionAverage> positions;
  FitResult fit;                       // the certified parameters
  std::optional<FitResult> invariant;  // invariant residuals per position (one per position)
  std::optional<FitResult> full;       // full-vector residuals per position and axis
  Compensation compensation;
  std::optional<UncertaintyBudget> budget;  // the GUM budget, with --budget
  std::optional<records::ConformityReport> conformity;
  std::optional<CertificateDiagnosis> diagnosis;
  std::vector<std::string> warnings;  // recording warnings, missing traceability, ...
  // What the unit's static recording gave the fits, where one was given.
  std::optional<UnitStaticRecordingUse> unit_static_recording;
  // Where none was given: what standcald's unit.static_recording gave the run, in words, from
  // its header (run_unit_static_recording_words; empty where it says nothing).
  std::string run_unit_static_recording;
  double coverage_factor = records::kDefaultCoverageFactor;
  std::string issued_utc;  // when the certificate was made
  std::string issuing_software_version;
  std::optional<LabIdentity> lab;  // who issues it (--lab)
  std::string certificate_number;
};

// What `standcal certificate` was asked for.
struct CertificateRequest {
  std::string state_dir;  // with run_id: STATE/runs/RUN_ID/{run.json,recording.csv,result.json}
  std::string run_id;
  std::string recording_path;      // instead: an imported / offline recording
  std::string limits_path;         // optional standcal-limits/1 file
  std::string budget_path;         // optional standcal-budget/1 file: the type B inputs
  std::string lab_path;            // optional standcal-lab/1 file: who issues and signs
  std::string certificate_number;  // default: default_certificate_number()
  std::string unit_type;  // which limits apply (default: run.json's unit_type or the only one)
  std::string method = "joint";  // certified estimator: joint | full
  bool diagnose = false;  // run the diagnosis now (else use RUN_DIR/diagnosis.json if present)
  // The fits' noise weighting (`standcal fit`'s --noise and --bias-instability-*); where it gives
  // nothing of the unit's wander, the one the recording's header says its run was made with,
  // else its own long dwell's (take_unit_wander): the run's result weighed with the same.
  FitNoiseOptions noise;
  // `--unit-static-recording`: a long static recording of the unit (g or m/s^2), whose pinned
  // wander the fits take after the header's and before the recording's own long dwell's, and
  // the diagnosis tests against (take_unit_wander_with_static_recording). Null: none.
  std::shared_ptr<const RawInput> unit_static_recording;
};

// Loads the run (or recording), refits it, applies the limits and the diagnosis. Throws
// std::runtime_error with a one-line reason naming the file or key that was wrong.
CertificateInput prepare_certificate(const CertificateRequest& request);

// Reduces a diagnose_to_json() document (e.g. RUN_DIR/diagnosis.json).
CertificateDiagnosis certificate_diagnosis_from_json(const nlohmann::json& doc,
                                                     const std::string& origin);

// The certificate page.
std::string render_certificate_html(const CertificateInput& input);

}  // namespace standcal::report
