// `standcal simulate` and `standcal fit`: the offline calibration commands.
#include <cstdio>
#include <fstream>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "calib/allan.hpp"
#include "calib/atomic_file.hpp"
#include "calib/averaging.hpp"
#include "calib/compensation.hpp"
#include "calib/full_estimator.hpp"
#include "calib/invariant_estimator.hpp"
#include "calib/json_text.hpp"
#include "calib/norm_calibration.hpp"
#include "calib/programs.hpp"
#include "calib/raw_input.hpp"
#include "calib/recording.hpp"
#include "calib/recording_digest.hpp"
#include "calib/report.hpp"
#include "calib/simulator.hpp"
#include "calib/uncertainty_budget.hpp"
#include "calib/units.hpp"
#include "tools/cli_checks.hpp"
#include "tools/standcal/commands.hpp"
#include "tools/standcal/input_options.hpp"
#include "tools/standcal/threaded_rows.hpp"

namespace standcal::cli {

namespace {

struct SimulateOptions {
  std::string program = "paper9";
  std::uint64_t seed = 1;
  std::string output;
  std::string truth_out;
  std::string model_in;
  std::string unit_serial = "AU-SIM";
  double alpha1_start_deg = 0;
  RunTiming timing;
  std::string fit_method;
};

struct FitOptions {
  std::string recording;
  std::string method = "auto";
  InputCliOptions input;
  bool json = false;
  std::string compensation;
  std::string budget;  // standcal-budget/1: the GUM budget's type B inputs
  std::string mounting = "common";
  NoiseCliOptions noise;
  UnitStaticCliOptions unit_static;  // a long static recording of the unit
};

void run_simulate(const SimulateOptions& o) {
  SimulationRequest req;
  req.program = load_program(o.program, o.alpha1_start_deg);
  req.truth = o.model_in.empty() ? default_truth() : load_truth(o.model_in);
  req.timing = o.timing;
  req.seed = o.seed;
  req.unit_serial = o.unit_serial;
  const Recording rec = simulate_run(req);
  write_recording(rec, o.output);
  if (!o.truth_out.empty()) save_truth(req.truth, o.truth_out);
  std::fprintf(stderr, "simulated %s: %zu positions, %zu samples, %.0f s of run -> %s\n",
               req.program.name.c_str(), req.program.positions.size(), rec.samples.size(),
               rec.samples.empty() ? 0.0 : rec.samples.back().t_s, o.output.c_str());
}

FitNoiseOptions noise_weighting(const FitOptions& o) { return fit_noise_options(o.noise); }

// The stand methods, weighted with `noise`.
FitResult fit_with(const FitOptions& o, const std::string& method,
                   const std::vector<PositionAverage>& averages, const FitNoiseOptions& noise) {
  if (method == "joint") return fit_invariant_joint(averages, noise);
  if (method == "paper-sequential") return fit_paper_sequential(averages);
  if (method == "full") {
    FullFitOptions full;
    full.noise = noise;
    full.mounting =
        o.mounting == "per-mount" ? MountingModel::per_mount : MountingModel::common_fixture;
    return fit_full_vector(averages, full);
  }
  throw std::runtime_error("unknown fit method '" + method +
                           "' (joint, paper-sequential, full, norm)");
}

void save_compensation(const Compensation& c, const std::string& path) {
  const std::string stem = write_compensation(c, path);
  std::fprintf(stderr, "compensation written to %s.json and %s.csv\n", stem.c_str(), stem.c_str());
}

void run_norm_fit(const FitOptions& o, const RawInput& in) {
  NormCalibrationOptions options;
  options.fit.noise = noise_weighting(o);
  if (o.unit_static.given()) {
    options.unit_static_recording =
        std::make_shared<RawInput>(read_unit_static_recording(o.unit_static));
    print_warnings(options.unit_static_recording->warnings);
  }
  const NormCalibration c = calibrate_without_angles(in, options);
  print_warnings({gaps_warning(c, in)});
  if (o.json) {
    std::cout << json_text(norm_calibration_to_json(c, in)) << "\n";
  } else {
    std::cout << format_norm_report(c, in);
  }
  if (!o.compensation.empty()) save_compensation(make_compensation(c.fit, in), o.compensation);
}

// The stand methods on averages and the header alone: from a streamed file, or from a
// recording read whole (any other format or reading option).
void fit_stand_averages(const FitOptions& o, const std::string& method, const Recording& rec,
                        std::vector<PositionAverage> averages, std::optional<AllanFinding> allan) {
  // Nothing of the unit's wander given: the one its run was made with (the header), else the
  // one the unit's static recording pins, else the one the recording's own long dwell pins.
  FitNoiseOptions noise = noise_weighting(o);
  std::optional<UnitStaticAllan> static_allan;
  if (o.unit_static.given())
    static_allan =
        stand_unit_static_allan(read_unit_static_recording(o.unit_static), rec.g_local_mps2);
  std::optional<UnitStaticRecordingUse> unit_static = take_unit_wander_with_static_recording(
      noise, rec, allan, static_allan ? &*static_allan : nullptr);
  if (unit_static) print_warnings(unit_static->warnings);
  FitResult fit = fit_with(o, method, averages, noise);
  if (unit_static) settle_unit_static_use(*unit_static, fit.noise);
  fit.noise.allan = std::move(allan);
  std::optional<Compensation> compensation;  // made before the report takes the averages
  if (!o.compensation.empty()) {
    compensation = make_compensation(fit, rec.g_local_mps2);
    compensation->identity = compensation_identity(rec, averages);
  }
  std::optional<UncertaintyBudget> budget;
  if (!o.budget.empty()) {
    const MountingModel mounting =
        o.mounting == "per-mount" ? MountingModel::per_mount : MountingModel::common_fixture;
    budget = evaluate_budget(averages, fit, budget_estimator(method, fit, mounting),
                             load_budget_config(o.budget), rec.header_value("unit_type"),
                             rec.g_local_mps2);
  }
  if (o.json) {
    nlohmann::json j = fit_to_json(fit);
    if (budget) j["uncertainty_budget"] = budget_to_json(*budget);
    if (unit_static) j["unit_static_recording"] = unit_static_recording_json(*unit_static);
    std::cout << json_text(j) << "\n";
  } else {
    ReportContext context = report_context(rec, std::move(averages));
    if (unit_static) {
      context.unit_static_recording = unit_static_recording_words(*unit_static);
      context.warnings.insert(context.warnings.end(), unit_static->warnings.begin(),
                              unit_static->warnings.end());
    }
    std::cout << format_report(fit, context);
    if (budget) std::cout << format_budget_summary(*budget);
  }
  if (compensation) save_compensation(*compensation, o.compensation);
}

void run_fit(const FitOptions& o) {
  if (!o.budget.empty() && o.method == "norm") {
    throw std::runtime_error(
        "--budget: the uncertainty budget propagates the stand's tolerances and needs a stand "
        "method (joint, full), not norm");
  }
  if (o.method != "norm" && streams_as_stand_recording(o.input, o.recording)) {
    const std::string method = o.method == "auto" ? "joint" : o.method;
    // Before the recording is read.
    check_unit_static_recording(o.unit_static.path, method, o.noise);
    RecordingDigest digest = digest_on_two_threads(o.recording, digest_options(o.input));
    print_warnings(digest.recording.warnings);
    print_warnings({digest.allan_warning()});
    return fit_stand_averages(o, method, digest.recording, std::move(digest.averages),
                              digest.allan_finding());
  }
  const RawInput in = read_input(o.recording, input_options(o.input));
  print_warnings(in.warnings);
  const std::string method = o.method != "auto" ? o.method : in.recording ? "joint" : "norm";
  check_unit_static_recording(o.unit_static.path, method, o.noise);
  if (method == "norm") {
    if (!o.budget.empty()) {
      throw std::runtime_error(o.recording +
                               ": --budget propagates the stand's tolerances through a stand "
                               "method, and this file has no angles (the norm fit)");
    }
    return run_norm_fit(o, in);
  }
  if (!in.recording)
    throw std::runtime_error(o.recording + ": the " + method +
                             " method needs the stand's angles, and this " +
                             std::string(to_string(in.format)) +
                             " recording has none; use --method norm (attitude-free, |f| = g)");
  Recording rec = *in.recording;
  if (o.input.g_mps2 > 0) rec.use_given_g(o.input.g_mps2);
  AveragedRecording averaged = average_recording(rec);
  print_warnings({averaged.allan_warning});
  fit_stand_averages(o, method, rec, std::move(averaged.averages), std::move(averaged.allan));
}

void add_calibrate_commands(CLI::App& app) {
  auto sim_opts = std::make_shared<SimulateOptions>();
  CLI::App* sim = app.add_subcommand("simulate", "simulate a calibration run into a recording");
  sim->add_option("--program", sim_opts->program, "paper9, classic24 or a programme JSON file")
      ->capture_default_str();
  sim->add_option("--seed", sim_opts->seed, "random seed (same seed, same recording)")
      ->capture_default_str();
  sim->add_option("-o,--output", sim_opts->output, "recording to write")->required();
  sim->add_option("--truth", sim_opts->truth_out, "write the model used (JSON)");
  sim->add_option("--model", sim_opts->model_in, "simulate this model (JSON, as --truth writes)")
      ->check(CLI::ExistingFile);
  sim->add_option("--unit-serial", sim_opts->unit_serial,
                  "the unit's serial, written in the recording's header")
      ->capture_default_str();
  sim->add_option("--alpha1-start-deg", sim_opts->alpha1_start_deg, "paper9's alpha1(1)")
      ->capture_default_str();
  // The daemon's run limits: past them a simulated run only exhausts the memory.
  sim->add_option("--dwell-s", sim_opts->timing.dwell_s)
      ->capture_default_str()
      ->check(cli_checks::positive_at_most(kMaxDwell_s));
  sim->add_option("--settle-s", sim_opts->timing.settle_s)
      ->capture_default_str()
      ->check(CLI::Range(0.0, kMaxSettle_s));
  sim->add_option("--rate-hz", sim_opts->timing.sample_rate_hz)
      ->capture_default_str()
      ->check(cli_checks::number_within(kMinSampleRate_hz, true, kMaxSampleRate_hz));
  sim->add_option("--move-rate-deg-s", sim_opts->timing.move_rate_deg_s)
      ->capture_default_str()
      ->check(cli_checks::kPositive);
  sim->add_option("--remount-s", sim_opts->timing.remount_s)
      ->capture_default_str()
      ->check(cli_checks::kNonNegative);
  sim->callback([sim_opts] { run_simulate(*sim_opts); });

  auto fit_opts = std::make_shared<FitOptions>();
  CLI::App* fit = app.add_subcommand("fit", "estimate the unit's parameters from a recording");
  fit->add_option("recording", fit_opts->recording,
                  "recording: standcal-recording/1, imu_tk text, delimited text or a means table "
                  "(told from the content)")
      ->required();
  fit->add_option("--method", fit_opts->method,
                  "auto (joint with stand angles, else norm) | joint | paper-sequential | full | "
                  "norm (attitude-free: |f| = g in each static interval)")
      ->check(CLI::IsMember({"auto", "joint", "paper-sequential", "full", "norm"}))
      ->capture_default_str();
  add_input_options(fit, fit_opts->input);
  fit->add_option("--mounting", fit_opts->mounting,
                  "full method, re-mounted programmes: common (one rigid fixture) | per-mount")
      ->check(CLI::IsMember({"common", "per-mount"}))
      ->capture_default_str();
  add_noise_options(fit, fit_opts->noise);
  add_unit_static_recording_option(fit, fit_opts->unit_static,
                                   "the wander its Allan curves pin is taken as the unit's, or "
                                   "where they show none, they bound the wander the fit's "
                                   "sigmas allow for, or where they see one they do not pin, "
                                   "they put a floor under its correlation time");
  fit->add_flag("--json", fit_opts->json, "machine-readable output");
  fit->add_option("--compensation", fit_opts->compensation,
                  "write the compensation (bias, correction matrix) as FILE.json and FILE.csv");
  fit->add_option(
         "--budget", fit_opts->budget,
         "add the GUM uncertainty budget: type B inputs (stand tolerances, g, temperature) from a "
         "standcal-budget/1 file (docs/calibration.md)")
      ->check(CLI::ExistingFile);
  fit->callback([fit_opts] { run_fit(*fit_opts); });
}

const bool calibrate_commands_registered = register_command_group(add_calibrate_commands);

}  // namespace

}  // namespace standcal::cli
