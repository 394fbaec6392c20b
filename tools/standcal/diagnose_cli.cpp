// `standcal diagnose`: where a recording and the calibration model disagree, what physics
// the model left out, how big it is, and whether adding it makes model and data agree.
#include <cstdio>
#include <fstream>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "calib/allan.hpp"
#include "calib/atomic_file.hpp"
#include "calib/diagnosis/diagnosis.hpp"
#include "calib/json_text.hpp"
#include "calib/norm_calibration.hpp"
#include "calib/raw_input.hpp"
#include "calib/recording.hpp"
#include "calib/simulator.hpp"
#include "calib/units.hpp"
#include "report/diagnosis/diagnosis_report.hpp"
#include "tools/standcal/commands.hpp"
#include "tools/standcal/input_options.hpp"

namespace standcal::cli {

namespace {

struct DiagnoseCliOptions {
  std::string recording;
  bool json = false;
  std::string report;
  std::string model_out;
  // The unit's bias instability as its data sheet or a static recording gives it.
  WanderCliOptions wander;
  InputCliOptions input;
  UnitStaticCliOptions unit_static;  // the unit's static recording itself
};

DiagnoseOptions diagnose_options(const DiagnoseCliOptions& o) {
  DiagnoseOptions d;
  const GivenWander w = o.wander.given();
  d.specified_wander = w.specified();
  d.known_tau = w.known_tau;
  return d;
}

// The wander the unit's static recording pins, as the one the terms are tested against: after
// the one the recording's header gives (what its run was made with), as the fits take it; where
// it pins none, the floor its curves put under the correlation time, which the diagnosis weighs
// beside the recording's own as the fits do (take_unit_wander), and say_diagnosis_static_tau_floor
// settles. No bound on the wander: the diagnosis's selection weighs none (the fits' "bound").
std::optional<UnitStaticRecordingUse> take_static_wander(const DiagnoseCliOptions& o,
                                                         const Recording& rec,
                                                         DiagnoseOptions& options) {
  if (!o.unit_static.given()) return std::nullopt;
  FitNoiseOptions fit;
  fit.specified = options.specified_wander;
  fit.known_tau = options.known_tau;
  const UnitStaticAllan unit_static =
      stand_unit_static_allan(read_unit_static_recording(o.unit_static), rec.g_local_mps2);
  // Nothing of the recording's own: the diagnosis takes its long dwell's wander itself.
  take_header_wander(fit, rec);
  UnitStaticRecordingUse use = take_static_recording_pinned_wander(fit, unit_static);
  if (use.gave == "wander") {
    options.give_static_recording_wander(use.wander);
    return use;
  }
  if (unit_static.allan.wander_curves)
    use.why += ": the diagnosis tests the terms against a wander they pin, and weighs no bound";
  options.unit_static_tau_floor_s = unit_static.allan.wander_tau_floor_s;  // 0: none
  use.tau_floor_s = unit_static.allan.wander_tau_floor_s;
  return use;
}

// A stand recording is diagnosed as it is; one without angles through the norm fit.
std::pair<Diagnosis, Recording> diagnose_stand_recording(
    const DiagnoseCliOptions& o, Recording rec,
    std::optional<UnitStaticRecordingUse>& unit_static) {
  if (o.input.g_mps2 > 0) rec.use_given_g(o.input.g_mps2);
  print_warnings(rec.warnings);
  print_warnings({no_sample_period_warning(rec)});
  DiagnoseOptions options = diagnose_options(o);
  unit_static = take_static_wander(o, rec, options);
  Diagnosis d = diagnose_recording(rec, options);
  if (unit_static)
    say_diagnosis_static_tau_floor(*unit_static, d.tau_floor_from, d.tau_floor_outcome, d.noise,
                                   false);
  return {std::move(d), std::move(rec)};
}

// `unit_static`: what the unit's static recording gave, where one was given.
std::pair<Diagnosis, Recording> diagnose_input(const DiagnoseCliOptions& o,
                                               std::optional<UnitStaticRecordingUse>& unit_static) {
  // A stand recording is read straight into its samples: no copy of the text, no raw columns.
  if (streams_as_stand_recording(o.input, o.recording)) {
    Recording rec = read_recording(o.recording);
    // The other reader applies it itself (read_input).
    if (o.input.rate_hz > 0) rec.use_given_sample_rate(o.input.rate_hz);
    return diagnose_stand_recording(o, std::move(rec), unit_static);
  }
  RawInput in = read_input(o.recording, input_options(o.input));
  if (in.recording) {
    in.recording->warnings = in.warnings;  // the reader's, with what the options changed
    return diagnose_stand_recording(o, std::move(*in.recording), unit_static);
  }
  print_warnings(in.warnings);
  if (in.format == InputFormat::means)
    throw std::runtime_error(o.recording +
                             ": a table of means has no samples; the diagnosis tests "
                             "settling and whiteness on the samples of each interval (fit it with "
                             "`standcal fit`)");
  NormCalibrationOptions calibrate;
  calibrate.stability = false;                    // the diagnosis does not report it
  o.wander.given().give_to(calibrate.fit.noise);  // as `fit`
  if (o.unit_static.given())
    calibrate.unit_static_recording =
        std::make_shared<RawInput>(read_unit_static_recording(o.unit_static));
  const NormCalibration calibration = calibrate_without_angles(in, calibrate);
  print_warnings({gaps_warning(calibration, in)});
  DiagnoseOptions options = diagnose_options(o);
  unit_static = calibration.unit_static_recording;
  if (unit_static && unit_static->gave == "wander")
    options.give_static_recording_wander(unit_static->wander);
  // The floor the norm fit took from it (kept or set aside): the diagnosis settles its own.
  if (unit_static && unit_static->gave != "wander")
    options.unit_static_tau_floor_s = unit_static->tau_floor_s;
  Diagnosis d = diagnose_without_angles(in, calibration, options);
  if (unit_static)
    say_diagnosis_static_tau_floor(*unit_static, d.tau_floor_from, d.tau_floor_outcome, d.noise,
                                   true);
  return {std::move(d), calibrated_recording(in, calibration)};
}

void run_diagnose(const DiagnoseCliOptions& o) {
  if (o.unit_static.given() && o.wander.given().given())
    throw CLI::ValidationError("--unit-static-recording",
                               "give the unit's wander either as a static recording or as "
                               "--bias-instability-*, not both");
  std::optional<UnitStaticRecordingUse> unit_static;
  const auto [d, rec] = diagnose_input(o, unit_static);
  if (unit_static) print_warnings(unit_static->warnings);
  set_exit_code(diagnosis_exit_code(d.verdict));
  if (!o.report.empty()) {
    write_file_atomically(o.report, report::diagnosis_html(d, rec), "the report");
    std::fprintf(stderr, "report written to %s\n", o.report.c_str());
  }
  if (!o.model_out.empty()) {
    save_truth(d.model, o.model_out);
    std::fprintf(stderr, "augmented model written to %s (standcal simulate --model %s)\n",
                 o.model_out.c_str(), o.model_out.c_str());
  }
  if (o.json) {
    nlohmann::json j = diagnose_to_json(d);
    if (unit_static) j["unit_static_recording"] = unit_static_recording_json(*unit_static);
    std::cout << json_text(j) << "\n";
    return;
  }
  std::cout << "verdict: " << d.verdict << "\n";
  for (const std::string& s : d.summary) std::cout << "  " << s << "\n";
  if (unit_static) std::cout << "  Noise, " << unit_static_recording_words(*unit_static) << "\n";
  std::cout << "where:\n";
  for (const std::string& s : d.located) std::cout << "  " << s << "\n";
  for (const ProposedPosition& p : d.proposed_positions)
    std::printf("proposed position: alpha1 %.0f deg, alpha2 %.0f deg (%s)\n", p.alpha1_deg,
                p.alpha2_deg, p.why.c_str());
}

void add_diagnose_commands(CLI::App& app) {
  auto opts = std::make_shared<DiagnoseCliOptions>();
  CLI::App* cmd = app.add_subcommand(
      "diagnose", "find where a recording and the model disagree and what physics is missing");
  cmd->add_option("recording", opts->recording,
                  "recording: standcal-recording/1, or one without angles (imu_tk text, delimited "
                  "text), diagnosed through the attitude-free norm fit")
      ->required();
  add_input_options(cmd, opts->input);
  cmd->add_flag("--json", opts->json, "machine-readable output");
  cmd->add_option(
      "--report", opts->report,
      "write an HTML report with plots (residuals before/after, located mismatch) to FILE");
  cmd->add_option("--model-out", opts->model_out,
                  "write the augmented model (standcal-model/1 JSON) to FILE");
  add_fit_wander_options(cmd, opts->wander,
                         "against which the terms are tested when the run does not show the "
                         "wander itself");
  add_unit_static_recording_option(cmd, opts->unit_static,
                                   "the wander its Allan curves pin is the one the terms are "
                                   "tested against");
  cmd->callback([opts] { run_diagnose(*opts); });
}

const bool diagnose_commands_registered = register_command_group(add_diagnose_commands);

}  // namespace

}  // namespace standcal::cli
