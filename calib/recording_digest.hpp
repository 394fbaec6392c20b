#pragma once
// A recording reduced while it is read: per-position averages and the pooled dwell Allan
// deviation, with only the dwell being read held in memory (as columns). This is how the
// offline commands that need no sample afterwards (`fit`, `noise`) read a file: the same
// numbers as average_positions / dwell_allan on the whole recording, at the cost of
// reading the file once (docs/performance.md).
#include <array>
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "calib/allan.hpp"
#include "calib/averaging.hpp"
#include "calib/position_average.hpp"
#include "calib/recording.hpp"

namespace standcal {

struct DigestOptions {
  std::optional<double> g_mps2;  // replaces the header's local gravity (m/s^2)
  // The sample rate where the header has none (Recording::use_given_sample_rate).
  std::optional<double> sample_rate_hz;
  bool averages = true;  // per-position averages
  // The pooled dwell Allan deviation; without it the averages' standard errors are sigma /
  // sqrt(n) as read, not widened for correlated samples as average_positions' are.
  bool allan = true;
};

struct RecordingDigest {
  Recording recording;  // header, columns and warnings; no samples
  std::size_t samples = 0;
  std::vector<PositionAverage> averages;  // as average_positions
  // As dwell_allan, when the recording allows one (else allan_unavailable says why).
  std::optional<DwellAllan> allan;
  std::string allan_unavailable;

  // The figures alone, as allan_finding(recording) gives them (the fit's `noise.allan`).
  std::optional<AllanFinding> allan_finding() const;
  // allan_unavailable_warning of a recording with no curve, or its gaps' (DwellGaps), as
  // AveragedRecording's, or "".
  std::string allan_warning() const;
};

// The reduction as a row sink: give it to stream_recording (or feed header() and row()
// yourself), then finish() with what the reader returned. Each finished dwell is averaged
// and added to the Allan accumulators, then dropped.
class RecordingDigester : public RecordingRowSink {
 public:
  explicit RecordingDigester(const DigestOptions& options = {});
  void header(const Recording& rec) override;
  void row(const RecordingSample& sample) override;
  void expect_rows(std::size_t rows) override;
  // The digest; `read` is the recording stream_recording returned (header and warnings).
  RecordingDigest finish(Recording&& read);

  // A file read in two parts at once (tools/standcal/threaded_rows.cpp): the digester of
  // the later part keeps what append needs (call after header()), is closed when its rows
  // end, and is appended to the first part's, which then holds what one digester given
  // every row in order would hold, bit for bit. Only with the sample rate known before the
  // rows (the header's, or the options').
  bool rate_known() const { return rate_known_; }
  void keep_for_append();
  void close_dwell();  // averages the dwell being read, if any
  void append(RecordingDigester&& later);

 private:
  void start_allan(double period_s);
  void finish_dwell();
  void feed_allan();
  void finish_allan(const Recording& read, RecordingDigest& out);

  DigestOptions options_;
  Recording header_;
  bool rate_known_ = false;
  std::size_t samples_ = 0;
  DwellSamples dwell_;
  std::vector<PositionAverage> averages_;
  std::array<std::optional<AllanAccumulator>, 3> allan_;
  std::vector<std::array<std::vector<double>, 3>> held_;  // dwells read before the rate is known
  std::vector<std::size_t> held_warmup_samples_;          // and their warm-ups' rows
  std::vector<double> steps_s_;                           // sample steps, when no rate header
  DwellGaps gaps_;                                        // the steps within dwells
};

// Reads and reduces the standcal-recording/1 file at `path`. Throws what read_recording
// throws (RecordingError naming file, line and column), and what average_positions throws
// when averages are asked for.
RecordingDigest digest_recording(const std::string& path, const DigestOptions& options = {});

// Whether the file at `path` is a regular file in standcal-recording/1 with the stand's
// commanded angles: its header and column line alone are read (a pipe: false).
bool is_stand_recording(const std::string& path);

}  // namespace standcal
