#include "tools/standcal/input_options.hpp"

#include <cstdio>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "calib/recording_digest.hpp"
#include "calib/text.hpp"
#include "tools/cli_checks.hpp"

namespace standcal::cli {

std::vector<CLI::Option*> add_reading_options(CLI::App* cmd, InputCliOptions& o,
                                              const std::string& prefix, const std::string& of) {
  const auto name = [&prefix](const char* option) { return input_option_name(prefix, option); };
  const auto help = [&of](const std::string& text) { return of.empty() ? text : of + ": " + text; };
  return {
      cmd->add_option(name("format"), o.format,
                      help("auto (told from the content) | standcal | imu_tk | delimited | means"))
          ->check(CLI::IsMember({"auto", "standcal", "imu_tk", "delimited", "means"}))
          ->capture_default_str(),
      cmd->add_option(name("columns"), o.columns,
                      help("the three accelerometer columns, by header name or 1-based index: "
                           "x,y,z")),
      cmd->add_option(name("rate-hz"), o.rate_hz,
                      help("sample rate: the times of rows without a time column; else the rate "
                           "of a file whose header states none"))
          ->check(cli_checks::number_within(kMinSampleRate_hz, true, kMaxSampleRate_hz)),
      cmd->add_option(name("skip-lines"), o.skip_lines,
                      help("preamble lines before the header or first row"))
          ->check(cli_checks::kNonNegative),
      cmd->add_option(name("units"), o.units, help("auto | counts | g | mps2"))
          ->check(CLI::IsMember({"auto", "counts", "g", "mps2"}))
          ->capture_default_str(),
  };
}

void add_input_options(CLI::App* cmd, InputCliOptions& o) {
  add_reading_options(cmd, o);
  cmd->add_option("--g-mps2", o.g_mps2, "local gravity (overrides the file's)")
      ->check(CLI::Range(9.7, 9.9));
}

InputOptions input_options(const InputCliOptions& o, const std::string& prefix) {
  InputOptions in;
  in.format = parse_input_format(o.format);
  in.units = parse_input_units(o.units);
  if (!o.columns.empty()) in.columns = split_at_commas(o.columns);
  if (o.rate_hz > 0) in.rate_hz = o.rate_hz;
  in.skip_lines = o.skip_lines;
  if (o.g_mps2 > 0) in.g_mps2 = o.g_mps2;
  in.option_prefix = prefix;
  return in;
}

DigestOptions digest_options(const InputCliOptions& o) {
  DigestOptions digest;
  if (o.g_mps2 > 0) digest.g_mps2 = o.g_mps2;
  if (o.rate_hz > 0) digest.sample_rate_hz = o.rate_hz;
  return digest;
}

bool streams_as_stand_recording(const InputCliOptions& o, const std::string& path) {
  const bool default_reading = (o.format == "auto" || o.format == "standcal") &&
                               o.columns.empty() && o.skip_lines == 0 &&
                               (o.units == "auto" || o.units == "mps2");
  return default_reading && is_stand_recording(path);
}

void print_warnings(const std::vector<std::string>& warnings) {
  for (const std::string& w : warnings)
    if (!w.empty()) std::fprintf(stderr, "warning: %s\n", w.c_str());
}

void add_noise_options(CLI::App* cmd, NoiseCliOptions& o) {
  cmd->add_option("--noise", o.noise,
                  "estimate: bias wander between dwells estimated from the run and weighted for "
                  "when significant (docs/calibration.md) | white: every dwell mean independent")
      ->check(CLI::IsMember({"estimate", "white"}))
      ->capture_default_str();
  add_fit_wander_options(cmd, o.wander,
                         "used when the run alone does not show it; a correlation time given is "
                         "taken as known, and the run estimates the wander's size at it; with "
                         "both given, a wander the run shows is weighted as this one unless the "
                         "run departs from it (P < 0.01); neither given: the one a standcald "
                         "recording's header says its run was made with, else its own long "
                         "dwell's");
}

void add_fit_wander_options(CLI::App* cmd, WanderCliOptions& o, const std::string& use) {
  add_wander_options(cmd, o.bias_instability_ug, o.bias_instability_tau_s, use, &o.tau_given);
  cmd->add_option("--bias-instability-tau-max-s", o.bias_instability_tau_max_s,
                  "with --bias-instability-tau-s T: the correlation time lies between T and this "
                  "(the range `standcal noise` gives from a static recording); the biases' "
                  "sigmas are averaged over it as this run's likelihood weighs it")
      ->check(cli_checks::kPositive);
}

GivenWander WanderCliOptions::given() const {
  return {bias_instability_ug, bias_instability_tau_s, known_tau()};
}

GaussMarkovNoise WanderCliOptions::specified() const { return given().specified(); }

std::optional<KnownTau> WanderCliOptions::known_tau() const {
  if (bias_instability_tau_max_s > 0 && !tau_given)
    throw CLI::ValidationError("--bias-instability-tau-max-s",
                               "a range needs its lower end too: --bias-instability-tau-s");
  if (!tau_given) return std::nullopt;
  if (bias_instability_tau_max_s == 0)
    return KnownTau{bias_instability_tau_s, bias_instability_tau_s};
  if (bias_instability_tau_max_s < bias_instability_tau_s)
    throw CLI::ValidationError(
        "--bias-instability-tau-max-s",
        round_trip_text(bias_instability_tau_max_s) + " s is below --bias-instability-tau-s " +
            round_trip_text(bias_instability_tau_s) + " s: the range is MIN to MAX");
  return KnownTau{bias_instability_tau_s, bias_instability_tau_max_s};
}

void add_wander_options(CLI::App* cmd, double& sigma_ug, double& tau_s, const std::string& use,
                        bool* tau_given) {
  cmd->add_option("--bias-instability-ug", sigma_ug,
                  "the unit's Gauss-Markov bias wander (steady-state sigma per axis, ug; from its "
                  "data sheet, `standcal fit`'s noise report or a static recording), " +
                      use)
      ->check(cli_checks::kNonNegative)
      ->capture_default_str();
  CLI::Option* tau = cmd->add_option("--bias-instability-tau-s", tau_s, "its correlation time, s")
                         ->check(cli_checks::kPositive)
                         ->capture_default_str();
  if (tau_given) tau->each([tau_given](const std::string&) { *tau_given = true; });
}

FitNoiseOptions fit_noise_options(const NoiseCliOptions& o) {
  FitNoiseOptions n;
  n.mode = o.noise == "white" ? FitNoiseOptions::Mode::white : FitNoiseOptions::Mode::estimate;
  o.wander.given().give_to(n);
  return n;
}

namespace {
constexpr const char* kUnitStaticPrefix = "unit-static-";
}  // namespace

CLI::Option* add_unit_static_recording_option(CLI::App* cmd, UnitStaticCliOptions& o,
                                              const std::string& gives) {
  constexpr const char* kGroup = "The unit's static recording";
  CLI::Option* path =
      cmd->add_option("--unit-static-recording", o.path,
                      "a long static recording of the same unit (hours; g or m/s^2, or counts "
                      "beside a norm fit's counts), read by the --unit-static-* options below "
                      "(not the run's): " +
                          gives)
          ->check(cli_checks::kUtf8Text & CLI::ExistingFile)
          ->group(kGroup);
  for (CLI::Option* reading :
       add_reading_options(cmd, o.input, kUnitStaticPrefix, "how the static recording is read"))
    reading->needs(path)->group(kGroup);
  return path;
}

std::string unit_static_reading_args(const InputCliOptions& o) {
  const auto arg = [](const char* name, const std::string& value) {
    return " " + input_option_name(kUnitStaticPrefix, name) + " " + value;
  };
  std::string out;
  if (o.format != "auto") out += arg("format", o.format);
  if (!o.columns.empty()) out += arg("columns", o.columns);
  if (o.rate_hz > 0) out += arg("rate-hz", round_trip_text(o.rate_hz));
  if (o.skip_lines > 0) out += arg("skip-lines", std::to_string(o.skip_lines));
  if (o.units != "auto") out += arg("units", o.units);
  return out;
}

std::string unit_static_reading_keys(const InputCliOptions& o) {
  nlohmann::json keys = nlohmann::json::object();
  if (o.format != "auto") keys["format"] = o.format;
  if (!o.columns.empty()) keys["columns"] = o.columns;
  if (o.rate_hz > 0) keys["rate_hz"] = o.rate_hz;
  if (o.skip_lines > 0) keys["skip_lines"] = o.skip_lines;
  if (o.units != "auto") keys["units"] = o.units;
  return keys.empty() ? "" : keys.dump();
}

RawInput read_unit_static_recording(const UnitStaticCliOptions& o) {
  RawInput s = read_input(o.path, input_options(o.input, kUnitStaticPrefix));
  drop_assumed_gravity_warning(s);
  return s;
}

// --unit-static-recording: for the fits that model the wander, and not beside one given
// outright.
void check_unit_static_recording(const std::string& static_path, const std::string& method,
                                 const NoiseCliOptions& noise) {
  if (static_path.empty()) return;
  if (method == "paper-sequential")
    throw CLI::ValidationError("--unit-static-recording",
                               "the paper-sequential method models no bias wander; use joint, "
                               "full or norm");
  if (noise.noise == "white")
    throw CLI::ValidationError("--unit-static-recording",
                               "--noise white weighs no wander, so the static recording would "
                               "give the fit nothing");
  if (noise.wander.bias_instability_ug > 0 || noise.wander.tau_given)
    throw CLI::ValidationError("--unit-static-recording",
                               "give the unit's wander either as a static recording or as "
                               "--bias-instability-*, not both");
}

}  // namespace standcal::cli
