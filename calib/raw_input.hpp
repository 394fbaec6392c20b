#pragma once
// One reader for every recording a bench engineer brings: standcal's own format (with or
// without angle columns), imu_tk's whitespace text `t x y z`, delimited text with a header
// that names the accelerometer columns, and tables of static means. The format is told
// from the content, never from the file name (`InputOptions::format` overrides); units
// from the column names or the values (`units` overrides). Every error names file, line
// and column (RecordingError), and a file the reader cannot make sense of is refused
// rather than guessed at.
//
// Raw samples are kept as compact columns: one value per sample and axis, in the input's
// own units (counts, g or m/s^2), because the static-interval detector and the Allan
// deviation need every sample and nothing else.
#include <array>
#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "calib/model.hpp"
#include "calib/recording.hpp"
#include "calib/units.hpp"

namespace standcal {

enum class InputFormat {
  automatic,  // detected from the content
  standcal,   // standcal-recording/1
  imu_tk,     // whitespace-separated `t x y z` rows, no header (imu_tk's test files)
  delimited,  // comma, semicolon, tab or space separated, with a header line
  means,      // one row per static orientation: the three means, optional n and standard errors
};

enum class InputUnits {
  automatic,  // from the column names, else from the values
  counts,     // raw ADC counts of unknown scale and offset
  g,          // specific force in g
  mps2,       // specific force in m/s^2
};

std::string_view to_string(InputFormat f);
std::string_view to_string(InputUnits u);
// Parses a command-line spelling ("auto", "standcal", "imu_tk", "delimited", "means";
// "auto", "counts", "g", "mps2"); throws std::invalid_argument naming the allowed values.
InputFormat parse_input_format(std::string_view s);
InputUnits parse_input_units(std::string_view s);

struct InputOptions {
  InputFormat format = InputFormat::automatic;
  // The three accelerometer columns (x, y, z) by header name or 1-based index; empty: found
  // by name (fx/fy/fz, ax/ay/az, acc_x..., x/y/z, any case, with or without unit suffixes).
  std::vector<std::string> columns;
  // The sample rate: it gives the times of rows without a time column (over a header's
  // rate); otherwise the rate of a file that states none (over its steps').
  std::optional<double> rate_hz;
  int skip_lines = 0;  // preamble lines before the header (or the first row)
  InputUnits units = InputUnits::automatic;
  std::optional<double> g_mps2;  // local gravity; overrides the file's own
  // How the caller names these options in the reader's messages: a command line's prefix
  // ("unit-static-": --unit-static-columns, for the unit's static recording beside a run's),
  // or a configuration section ending in '.' ("unit.static_recording_input.":
  // unit.static_recording_input.columns).
  std::string option_prefix;
};

// An input option `name` ("rate-hz") as the caller names it (InputOptions::option_prefix):
// "--" + prefix + name, or for a configuration section prefix + name with '_' for '-'.
std::string input_option_name(const std::string& prefix, std::string_view name);

// One row of a table of static means.
struct StaticMeanRow {
  int line = 0;                        // 1-based line in the file
  Vec3 mean = Vec3::Zero();            // input units
  std::optional<double> samples;       // samples averaged, when given
  std::optional<Vec3> standard_error;  // standard error of the mean, input units, when given
};

struct RawInput {
  std::string source;                           // file name, for messages
  InputFormat format = InputFormat::automatic;  // as read (never `automatic`)
  InputUnits units = InputUnits::automatic;     // as resolved (never `automatic`)
  std::string units_how;  // how the units were decided, in words ("column names fx_mps2...")
  double g_mps2 = kStandardGravity_mps2;
  bool g_given = false;  // from --g-mps2 or the file's header, not assumed

  // Raw samples (empty for a means table): time and the three axes, one entry per sample.
  std::vector<double> t_s;
  std::array<std::vector<double>, 3> axis;
  double sample_rate_hz = kNaN;  // from the header, --rate-hz, or the median time step
  // standcal recordings: the `pos` of each sample (its dwell); empty otherwise.
  std::vector<int> block;
  // standcal recordings with a pos column: the header's warm-up (Recording::warmup_s), the
  // front of block 0 that is no static interval of its own but feeds the curves.
  double warmup_s = 0;

  std::vector<StaticMeanRow> means;  // a means table's rows

  // standcal-recording/1 with its angle columns: the full recording, for the stand methods.
  std::optional<Recording> recording;

  std::vector<std::string> ignored_columns;  // columns read past (gyroscopes, counters...)
  std::vector<std::string> warnings;
  std::string option_prefix;  // InputOptions::option_prefix it was read with

  // The input option `name` ("rate-hz") as the command line that read this file names it.
  std::string option(std::string_view name) const { return input_option_name(option_prefix, name); }

  std::size_t size() const { return t_s.size(); }
  // Sample i as a vector, input units.
  Vec3 sample(std::size_t i) const { return {axis[0][i], axis[1][i], axis[2][i]}; }
};

// A standcal recording's samples as raw input: m/s^2, its dwell blocks, its gravity.
RawInput raw_input_of(const Recording& rec);

// A static recording read for its noise alone (the unit's, beside a run): its g only puts m/s^2
// in ug for the wander's size, where the fits take the run's g, so the reader's "assuming
// standard gravity ... a scale-factor error" warning is not so for it, and is dropped.
void drop_assumed_gravity_warning(RawInput& s);

// Reads a file (throws RecordingError naming file, line and column, or std::runtime_error
// when it cannot be opened).
RawInput read_input(const std::string& path, const InputOptions& options = {});
// Parses text; `source` names it in messages.
RawInput parse_input(std::string_view text, const std::string& source,
                     const InputOptions& options = {});

}  // namespace standcal
