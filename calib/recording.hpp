#pragma once
// Reader and writer of the recording interchange format `standcal-recording/1`
// (docs/recording-format.md). Every error names file, line and column.
#include <array>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "calib/model.hpp"
#include "calib/units.hpp"

namespace standcal {

inline constexpr std::string_view kRecordingFormat = "standcal-recording/1";
inline constexpr double kNoValue = std::numeric_limits<double>::quiet_NaN();

// One row. The small members come last, packed: a recording holds hundreds of thousands
// of these (88 bytes each, not 104: docs/performance.md).
struct RecordingSample {
  double t_s = 0;
  double alpha1_cmd_deg = 0;
  double alpha2_cmd_deg = 0;
  double alpha1_deg = kNoValue;  // angle-sensor readings, NaN when not available
  double alpha2_deg = kNoValue;
  Vec3 f_mps2 = Vec3::Zero();
  double temp_c = kNoValue;      // NaN when not measured
  double t_arrive_s = kNoValue;  // from the `t_arrive_s` column
  int pos = 0;
  std::int8_t approach = 0;    // +1/-1 from the `approach` column, 0 when absent
  std::optional<Mount> mount;  // from the `mount` column
};

// Which optional columns a recording carries (and a writer writes).
struct RecordingColumns {
  bool alpha_measured = true;
  bool temp = true;
  bool mount = false;
  bool t_arrive = false;
  bool approach = false;
};

// The unit's bias wander a run was made with (standcald's unit.bias_instability_*), as its
// recording's header carries it: unit_bias_instability_ug, _tau_s, _tau_max_s. 0 where absent.
// The fits of the recording take it as the unit's given wander (calib/noise_model.hpp,
// take_unit_wander), so that every later fit of a run weighs as the run's own did.
struct RecordedUnitWander {
  double size_ug = 0;    // steady-state sigma per axis (the largest axis's, with size_axes_ug)
  double tau_s = 0;      // its correlation time; 0: not given
  double tau_max_s = 0;  // with tau_s: the range tau_s-tau_max_s; 0: one value
  // Each axis's (unit_bias_instability_x_ug, _y_ug, _z_ug: all three or none); zero: size_ug.
  Vec3 size_axes_ug = Vec3::Zero();
};
inline constexpr const char* kHeaderUnitWanderUg = "unit_bias_instability_ug";
inline constexpr std::array<const char*, 3> kHeaderUnitWanderAxisUg = {
    "unit_bias_instability_x_ug", "unit_bias_instability_y_ug", "unit_bias_instability_z_ug"};
inline constexpr const char* kHeaderUnitWanderTauS = "unit_bias_instability_tau_s";
inline constexpr const char* kHeaderUnitWanderTauMaxS = "unit_bias_instability_tau_max_s";
// Where the wander those keys give came from, in words, when not from the configuration's
// figures (standcald's unit.static_recording): for the reader, not read back.
inline constexpr const char* kHeaderUnitWanderSource = "unit_bias_instability_source";
// The unit's static recording's Allan curves, where they show no wander (standcald's
// unit.static_recording; wander_curves_text): every fit of the run weighs them as a bound on
// the wander its sigmas allow for, where nothing of the unit's wander is given
// (take_header_static_curves).
inline constexpr const char* kHeaderUnitStaticCurves = "unit_static_allan_curves";
// Where those curves see a wander they do not pin, the floor they put under its correlation
// time (s; AllanFinding::wander_tau_floor_s): every fit of the run takes it as the static
// recording's own floor would be taken (take_higher_tau_floor).
inline constexpr const char* kHeaderUnitStaticTauFloorS = "unit_static_tau_floor_s";
// Why `text` is not such curves ("" where it is), which the reader refuses at its line: defined
// with the curves (parse_wander_curves, calib/allan.cpp), which include this header.
std::string wander_curves_text_error(std::string_view text);
// What a unit's wander can be, here and in standcald's unit.bias_instability_*.
inline constexpr double kMaxUnitWanderUg = 100000;
inline constexpr double kMinUnitWanderTauS = 1, kMaxUnitWanderTauS = 1e6;
inline constexpr const char* kHeaderWarmupS = "warmup_s";

struct Recording {
  std::string source;                                       // file name, for messages
  std::vector<std::pair<std::string, std::string>> header;  // every `# key: value`, in order
  double g_local_mps2 = kStandardGravity_mps2;
  bool g_from_header = false;
  double settle_s = kNoValue;
  double sample_rate_hz = kNoValue;
  std::optional<double> temp_ref_c;
  std::optional<Mount> default_mount;
  std::string unit_serial;
  std::string program;
  RecordedUnitWander unit_wander;
  // standcald's unit static recording's floor under the correlation time
  // (kHeaderUnitStaticTauFloorS), s; 0: none.
  double unit_static_tau_floor_s = 0;
  // The first warmup_s seconds of position 0's block are a warm-up (header `warmup_s`): the
  // unit held still to settle and to show its noise; they feed the Allan curves (the noise
  // model) and are left out of that position's mean. 0: none.
  double warmup_s = 0;
  RecordingColumns columns;
  std::vector<RecordingSample> samples;
  std::vector<std::string> warnings;  // e.g. truncated last line dropped, g assumed

  // The value of a header key, or empty when absent.
  std::string header_value(std::string_view key) const;
  // Sets (or replaces) a header key, keeping the order of first appearance.
  void set_header(const std::string& key, const std::string& value);
  // Local gravity the operator gave (--g-mps2): it replaces the header's, with a warning when
  // the two differ (g_option_replaces_header_warning), and the reader's "g assumed" warning
  // no longer holds. `option`: how the command line that gave it names it.
  void use_given_g(double g_mps2, std::string_view option = "--g-mps2");
  // The sample rate the operator gave (--rate-hz) for a recording with no sample_rate_hz
  // header: its Allan curves then need no period from the times' steps. A header's rate
  // is kept (it was written with the samples), with a warning when the two differ. Throws
  // std::invalid_argument for a rate no recording has (is_plausible_sample_rate).
  void use_given_sample_rate(double rate_hz, std::string_view option = "--rate-hz");
};

// Where position 0's warm-up ends (Recording::warmup_s after that position's first row), or
// -infinity without one: a row before it is the unit settling, not a measurement.
double warmup_end_s(const Recording& rec);
inline bool is_warmup_row(const RecordingSample& s, double warmup_end_s) {
  return s.pos == 0 && s.t_s < warmup_end_s;
}
// Whether consecutive rows `a`, `b` lie in one stretch of evenly spaced samples: one
// position's block, and the same side of its warm-up's end.
inline bool one_segment(const RecordingSample& a, const RecordingSample& b, double warmup_end_s) {
  return a.pos == b.pos && is_warmup_row(a, warmup_end_s) == is_warmup_row(b, warmup_end_s);
}

// "SOURCE: --rate-hz 100 is not used: the header's sample_rate_hz 25 was written with the
// samples", for a reader that keeps a header's rate over the option (named `option`).
std::string rate_option_not_used_warning(const std::string& source, double given_hz,
                                         double header_hz, std::string_view option = "--rate-hz");

// "SOURCE: --g-mps2 9.80665 replaces the header's g_local_mps2 9.81625 (-978.0 ppm): the scale
// factors take up the difference", for every reader where the option wins over the header.
std::string g_option_replaces_header_warning(const std::string& source, double given_mps2,
                                             double header_mps2,
                                             std::string_view option = "--g-mps2");

// The reader's warning that the recording has no g_local_mps2 header.
bool is_assumed_gravity_warning(std::string_view warning);

// The largest |value| an accelerometer column may hold, in counts, g or m/s^2: no
// converter counts this far (a 32-bit one stops at 4.3e9) and no unit is built for this
// force. A larger value is a corrupted field, and read as a sample it overflows the
// squares of the noise analysis (an Allan deviation of infinity).
inline constexpr double kMaxAbsAccelerometerValue = 1e12;
bool is_plausible_accelerometer_value(double v);
// What is wrong with such a value, for an error naming its line and column.
std::string implausible_accelerometer_value_text(double v);

// The other numbers a recording holds, bounded the same way: beyond these a value is a
// corrupted field, not a measurement, and read as one it overflows the arithmetic done on
// it (two times of 1e308 s differ by infinity; a temperature term squares 1e300) or
// carries no arcsecond (the sine of 1e300 degrees).
inline constexpr double kMaxAbsTime_s = 1e12;            // any time, after its unit
inline constexpr double kMaxAbsAngle_deg = 1e6;          // 2778 turns
inline constexpr double kLowestTemperature_c = -273.15;  // absolute zero
inline constexpr double kHighestTemperature_c = 1000;    // no accelerometer unit works there
inline constexpr double kMaxSampleRate_hz = 1e6;
inline constexpr double kMinSampleRate_hz = 1 / kMaxAbsTime_s;  // a period of at most 1e12 s
bool is_plausible_time(double t_s);
// "1e+13 s is not a time a recording holds (within +-1e12 s): a corrupted value?"
std::string implausible_time_text(double t_s);
// At least 1e-12 Hz and at most 1e6 Hz, with room for the rounding of a rate read from 1 MHz
// times written to the microsecond (1000000.0025 Hz). A period beyond the bound on any time
// is no period (1e-320 Hz: a period of infinity).
bool is_plausible_sample_rate(double rate_hz);
// "1e300 Hz is not a sample rate (at least 1e-12, at most 1e6 Hz)", of the rate as it was
// written.
std::string implausible_sample_rate_text(const std::string& rate_as_written);
bool is_plausible_temperature(double temp_c);
// The end of -273.15 ... 1000 degC that a temperature outside it is past: the lowest for one
// below it, else the highest.
double temperature_bound_past_c(double temp_c);
// What is wrong with such a temperature, in the words of the errors above.
std::string implausible_temperature_text(double temp_c);
// What in a row is beyond these bounds ("column 'temp_c': 1e+300 degC is not ..."), for a
// writer that must not write what the reader refuses; empty when nothing is.
std::string implausible_sample_text(const RecordingSample& sample);

// A bad recording: the message already names file, line and column.
class RecordingError : public std::runtime_error {
 public:
  RecordingError(const std::string& source, int line, int column, const std::string& what);
  const std::string& source() const { return source_; }
  int line() const { return line_; }
  int column() const { return column_; }

 private:
  std::string source_;
  int line_;
  int column_;
};

// Reads a recording file; throws RecordingError (or std::runtime_error if unreadable).
Recording read_recording(const std::string& path);
// Parses recording text; `source` names it in messages.
Recording parse_recording(std::string_view text, const std::string& source);

// Where a streamed recording's rows go, one at a time, in file order.
class RecordingRowSink {
 public:
  virtual ~RecordingRowSink() = default;
  // Once, after the header and the column line, before the first row: the recording
  // without samples (its g, settle time, rate, default mount and columns are known).
  virtual void header(const Recording& rec) = 0;
  // Every row, after it passed the reader's checks.
  virtual void row(const RecordingSample& sample) = 0;
  // Once, early: about how many rows the whole file holds (from its size and the first
  // rows' length), so storage can be reserved once instead of grown by copies. A hint.
  virtual void expect_rows(std::size_t rows) { (void)rows; }
};
// Reads a recording file without holding it: each row goes to `sink`, and the returned
// recording has the header, columns and warnings but no samples. The same checks and
// errors as read_recording.
Recording stream_recording(const std::string& path, RecordingRowSink& sink);

// The reader with its steps apart, for reading a large file in two parts at once (the
// CLI's `fit` and `noise`, tools/standcal/threaded_rows.cpp): the header, then the rows up
// to where a later part begins, which a RecordingPartReader reads on another thread
// meanwhile; then either the part continues these rows (continues_with) or the rows are
// read on from where they stopped, in order, so any error is told as the one-pass reader
// tells it.
class RecordingPartReader;
class RecordingReader {
 public:
  static constexpr std::size_t kToEnd = std::numeric_limits<std::size_t>::max();

  explicit RecordingReader(const std::string& path);  // throws as read_recording
  ~RecordingReader();
  RecordingReader(const RecordingReader&) = delete;
  RecordingReader& operator=(const RecordingReader&) = delete;

  // The header and column line; `sink` is given the recording without samples.
  const Recording& read_header(RecordingRowSink& sink);
  // The rows from where the last call stopped up to the line that starts at byte `stop`.
  void read_rows(RecordingRowSink& sink, std::size_t stop = kToEnd);
  // After the last rows: the recording without samples, with the reader's warnings.
  Recording finish();
  std::size_t bytes_total() const;  // the file's size (0 for a pipe)

  // Where a later part can begin with a dwell of its own: the start of the first row whose
  // position text differs from the row's before it, both rows after the line that byte
  // `from` falls in and starting no more than `within` bytes beyond it. Nothing when there
  // is none, or when the file at the path is no longer the one this reader opened.
  std::optional<std::size_t> dwell_start_after(std::size_t from, std::size_t within) const;
  // A reader of the rows from byte `begin` to the end, with this reader's columns. Made
  // after read_header, on this reader's thread; then read on any thread.
  RecordingPartReader part_from(std::size_t begin) const;
  // Whether `part`, read whole, continues the rows read here (time does not go back, no
  // position of the part appeared here): then its rows are this file's from `begin` on.
  bool continues_with(const RecordingPartReader& part) const;

 private:
  struct Impl;
  std::string path_;
  std::unique_ptr<Impl> impl_;
};

class RecordingPartReader {
 public:
  RecordingPartReader(RecordingPartReader&&) noexcept;
  ~RecordingPartReader();
  // Every row into `sink`, stopping early when `cancel` turns true. False on any error or
  // warning (a row cut off at the end, an error the sink raised): the part is then read
  // again in order by the RecordingReader, whose messages name the line.
  bool read(RecordingRowSink& sink, const std::atomic<bool>& cancel);

 private:
  friend class RecordingReader;
  RecordingPartReader();
  struct Impl;
  std::unique_ptr<Impl> impl_;
  bool read_ = false;
};

// Header block ("# key: value" lines + the column line) for a recording's columns.
std::string format_recording_header(const Recording& rec);
// Appends one CSV row per sample, in the columns of format_recording_header.
void append_recording_rows(std::string& out, const RecordingColumns& columns,
                           const std::vector<RecordingSample>& samples);
// Writes a whole recording atomically (temporary file, fsync, rename): a failed write
// never leaves a half file under `path`.
void write_recording(const Recording& rec, const std::string& path);

}  // namespace standcal
