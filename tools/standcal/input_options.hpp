#pragma once
// The options the offline commands share: the recording input `fit` and `diagnose` read
// (calib/raw_input.hpp), and the noise weighting `fit` and `records import` fit with
// (calib/noise_model.hpp): one spelling, one help text, one conversion.
#include <CLI/CLI.hpp>
#include <string>
#include <vector>

#include "calib/noise_model.hpp"
#include "calib/norm_calibration.hpp"
#include "calib/raw_input.hpp"
#include "calib/recording_digest.hpp"

namespace standcal::cli {

struct InputCliOptions {
  std::string format = "auto";
  std::string columns;
  double rate_hz = 0;
  int skip_lines = 0;
  std::string units = "auto";
  double g_mps2 = 0;
};

// --format, --columns, --rate-hz, --skip-lines, --units: how a file is read, each named
// --<prefix><name> and described as of `of` where a prefix is given.
std::vector<CLI::Option*> add_reading_options(CLI::App* cmd, InputCliOptions& o,
                                              const std::string& prefix = "",
                                              const std::string& of = "");
// The reading options and --g-mps2, the local gravity of the run a command fits.
void add_input_options(CLI::App* cmd, InputCliOptions& o);
// `prefix`: as add_reading_options named them, for the reader's messages.
InputOptions input_options(const InputCliOptions& o, const std::string& prefix = "");
// The same options for a stand recording that is streamed: --g-mps2 and --rate-hz.
DigestOptions digest_options(const InputCliOptions& o);
// The file is a standcal recording with the stand's angles and no option asks to read it
// otherwise: it can be streamed (calib/recording_digest.hpp) instead of read whole.
bool streams_as_stand_recording(const InputCliOptions& o, const std::string& path);
// The reader's warnings, one "warning: ..." line each on stderr.
void print_warnings(const std::vector<std::string>& warnings);

// The unit's bias wander as the commands that fit take it (fit, import, diagnose):
// --bias-instability-ug, --bias-instability-tau-s, --bias-instability-tau-max-s.
struct WanderCliOptions {
  double bias_instability_ug = 0;
  double bias_instability_tau_s = 300;
  double bias_instability_tau_max_s = 0;  // 0: not given
  bool tau_given = false;                 // --bias-instability-tau-s on the command line
  GivenWander given() const;
  GaussMarkovNoise specified() const;  // white when no size is given
  // The correlation time when given: one value, or the range up to --bias-instability-tau-max-s.
  // Throws CLI::ValidationError when the range is given without its lower end or upside down.
  std::optional<KnownTau> known_tau() const;
};
// `o` is written while the command line is parsed: it must outlive the parse.
void add_fit_wander_options(CLI::App* cmd, WanderCliOptions& o, const std::string& use);

// --noise and the wander's options.
struct NoiseCliOptions {
  std::string noise = "estimate";
  WanderCliOptions wander;
};
// `o` is written while the command line is parsed: it must outlive the parse.
void add_noise_options(CLI::App* cmd, NoiseCliOptions& o);
// --bias-instability-ug and --bias-instability-tau-s: the unit's Gauss-Markov bias wander
// (steady-state sigma per axis, ug; correlation time, s), one spelling and one check for
// every command; `use` says what the command does with it. `tau_given`, when given, is set
// when --bias-instability-tau-s is on the command line (it must outlive the parse).
void add_wander_options(CLI::App* cmd, double& sigma_ug, double& tau_s, const std::string& use,
                        bool* tau_given = nullptr);
FitNoiseOptions fit_noise_options(const NoiseCliOptions& o);

// The unit's static recording (`--unit-static-recording FILE`) and how it is read: the reading
// options under the prefix "unit-static-" (--unit-static-columns, --unit-static-units...),
// automatic by default; no g of its own (drop_assumed_gravity_warning). It is its own file, perhaps
// of another logger than the run's, so no command reads it with the run's options: each reads it
// alike.
struct UnitStaticCliOptions {
  std::string path;
  InputCliOptions input;
  bool given() const { return !path.empty(); }
};
// Adds --unit-static-recording (the file named in the JSON and the records: UTF-8), whose help
// says what it gives the command (`gives`), and its input options, which need it. `o` is
// written while the command line is parsed: it must outlive the parse.
CLI::Option* add_unit_static_recording_option(CLI::App* cmd, UnitStaticCliOptions& o,
                                              const std::string& gives);
// How a file read by `o` is read again as the unit's static recording: the --unit-static-*
// options that are not the defaults (" --unit-static-rate-hz 10"), and standcald's
// unit.static_recording_input as JSON ({"rate_hz":10}); both empty where all are. No g: it has
// none of its own.
std::string unit_static_reading_args(const InputCliOptions& o);
std::string unit_static_reading_keys(const InputCliOptions& o);
// The unit's static recording read by its own input options; the reader's messages name those.
// Its warnings are the caller's to print: the fits carry them on (UnitStaticRecordingUse).
RawInput read_unit_static_recording(const UnitStaticCliOptions& o);

// `--unit-static-recording PATH` of `fit`, `import` and `certificate` with `method`: refused,
// naming the option, for the paper-sequential method, with --noise white and beside
// --bias-instability-*. Nothing where PATH is empty.
void check_unit_static_recording(const std::string& static_path, const std::string& method,
                                 const NoiseCliOptions& noise);

}  // namespace standcal::cli
