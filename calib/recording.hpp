#pragma once
// Reader and writer of the recording interchange format `standcal-recording/1`
// (docs/recording-format.md). Every error names file, line and column.
#include <cmath>
#include <cstdint>
#include <limits>
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
  RecordingColumns columns;
  std::vector<RecordingSample> samples;
  std::vector<std::string> warnings;  // e.g. truncated last line dropped, g assumed

  // The value of a header key, or empty when absent.
  std::string header_value(std::string_view key) const;
  // Sets (or replaces) a header key, keeping the order of first appearance.
  void set_header(const std::string& key, const std::string& value);
  // Local gravity the operator gave (--g-mps2): it replaces the header's, and the reader's
  // "g assumed" warning no longer holds.
  void use_given_g(double g_mps2);
};

// The reader's warning that the recording has no g_local_mps2 header.
bool is_assumed_gravity_warning(std::string_view warning);

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

// Header block ("# key: value" lines + the column line) for a recording's columns.
std::string format_recording_header(const Recording& rec);
// Appends one CSV row per sample, in the columns of format_recording_header.
void append_recording_rows(std::string& out, const RecordingColumns& columns,
                           const std::vector<RecordingSample>& samples);
// Writes a whole recording atomically (temporary file, fsync, rename): a failed write
// never leaves a half file under `path`.
void write_recording(const Recording& rec, const std::string& path);

}  // namespace standcal
