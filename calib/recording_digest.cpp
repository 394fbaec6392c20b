#include "calib/recording_digest.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <iterator>
#include <stdexcept>
#include <utility>

#include "calib/averaging.hpp"
#include "calib/line_source.hpp"
#include "calib/units.hpp"

namespace standcal {

RecordingDigester::RecordingDigester(const DigestOptions& options) : options_(options) {
  dwell_.with_temperature = options.averages;  // the Allan deviation needs the force alone
}

// The longest dwell is at most the whole file: reserving that much costs address space,
// not memory (pages count only once written), and a long dwell is never copied to grow.
// One row more, for the phase the Allan accumulator appends in place.
void RecordingDigester::expect_rows(std::size_t rows) { dwell_.reserve(rows + 1); }

void RecordingDigester::header(const Recording& rec) {
  header_ = rec;
  dwell_.warmup_s = rec.warmup_s;
  if (options_.g_mps2) header_.use_given_g(*options_.g_mps2);
  if (options_.sample_rate_hz) header_.use_given_sample_rate(*options_.sample_rate_hz);
  rate_known_ = std::isfinite(header_.sample_rate_hz) && header_.sample_rate_hz > 0;
  if (rate_known_) start_allan(1.0 / header_.sample_rate_hz);
}

void RecordingDigester::row(const RecordingSample& s) {
  if (dwell_.size() > 0 && s.pos != dwell_.head.pos) finish_dwell();
  // The step from a warm-up to its dwell is no sample period (the two are segments apart).
  const bool after_warm_up = dwell_.ends_warm_up(s);
  if (dwell_.size() > 0 && allan_[0] && !after_warm_up)
    gaps_.add_step(s.t_s - dwell_.t_end_s, allan_[0]->sample_period_s());
  if (!rate_known_ && dwell_.size() > 0 && !after_warm_up)
    steps_s_.push_back(s.t_s - dwell_.t_end_s);
  dwell_.add(s);
  ++samples_;
}

RecordingDigest RecordingDigester::finish(Recording&& read) {
  close_dwell();
  RecordingDigest out;
  out.samples = samples_;
  if (options_.averages) {
    if (samples_ == 0) throw std::runtime_error(read.source + ": the recording has no samples");
    derive_missing_approaches(averages_);
    out.averages = std::move(averages_);
  }
  if (options_.allan) finish_allan(read, out);
  if (out.allan && out.allan->sample_correlation && !out.averages.empty())
    widen_for_sample_correlation(out.averages, *out.allan->sample_correlation);
  if (options_.g_mps2) read.use_given_g(*options_.g_mps2);
  if (options_.sample_rate_hz) read.use_given_sample_rate(*options_.sample_rate_hz);
  out.recording = std::move(read);
  return out;
}

void RecordingDigester::keep_for_append() {
  for (auto& axis : allan_)
    if (axis) axis->keep_segment_sums();
}

void RecordingDigester::close_dwell() {
  if (dwell_.size() > 0) finish_dwell();
}

void RecordingDigester::append(RecordingDigester&& later) {
  if (!rate_known_ || !later.rate_known_)
    throw std::logic_error("RecordingDigester::append needs the sample rate before the rows");
  close_dwell();
  later.close_dwell();
  averages_.insert(averages_.end(), std::make_move_iterator(later.averages_.begin()),
                   std::make_move_iterator(later.averages_.end()));
  for (std::size_t a = 0; a < 3; ++a)
    if (allan_[a] && later.allan_[a]) allan_[a]->append(*later.allan_[a]);
  gaps_.add(later.gaps_);  // the one step across the split is not counted
  samples_ += later.samples_;
}

void RecordingDigester::start_allan(double period_s) {
  if (!options_.allan) return;
  for (auto& axis : allan_) axis.emplace(period_s);
}

void RecordingDigester::finish_dwell() {
  if (options_.averages) averages_.push_back(average_dwell(dwell_, header_));
  if (allan_[0]) {
    feed_allan();
  } else if (options_.allan) {
    held_.push_back(std::move(dwell_.f_mps2));  // no rate yet: kept until the end
    held_warmup_samples_.push_back(dwell_.warmup_samples);
    dwell_.f_mps2 = {};
  }
  dwell_.clear();
}

void RecordingDigester::feed_allan() {
  const double to_ug = 1.0 / header_.g_local_mps2 / kUg;
  const auto warm_up = static_cast<std::ptrdiff_t>(dwell_.warmup_samples);
  for (std::size_t a = 0; a < 3; ++a) {
    std::vector<double>& segment = dwell_.f_mps2[a];
    for (double& v : segment) v *= to_ug;
    if (warm_up > 0) {  // a segment of its own, as dwell_allan takes it
      std::vector<double> warm(segment.begin(), segment.begin() + warm_up);
      allan_[a]->add_segment(warm);
      segment.erase(segment.begin(), segment.begin() + warm_up);
    }
    if (!segment.empty()) allan_[a]->add_segment(segment);  // keeps its capacity for the next
  }
}

void RecordingDigester::finish_allan(const Recording& read, RecordingDigest& out) {
  if (samples_ < kMinAllanSamples) {
    out.allan_unavailable = read.source + ": too few samples for an Allan deviation";
    return;
  }
  if (!rate_known_) {
    const std::optional<double> step_s = median_step_s(steps_s_);  // kept: the gaps below
    if (!step_s) {
      out.allan_unavailable =
          read.source + ": cannot tell the sample rate (no sample_rate_hz header)";
      return;
    }
    if (const std::string why = unusable_step_text(*step_s); !why.empty()) {
      out.allan_unavailable = read.source + ": " + why;
      return;
    }
    start_allan(*step_s);
    for (double step : steps_s_) gaps_.add_step(step, *step_s);
    for (std::size_t k = 0; k < held_.size(); ++k) {
      dwell_.f_mps2 = std::move(held_[k]);
      dwell_.warmup_samples = held_warmup_samples_[k];
      feed_allan();
    }
  }
  out.allan =
      finish_dwell_allan(allan_[0]->sample_period_s(), {*allan_[0], *allan_[1], *allan_[2]}, gaps_);
}

std::optional<AllanFinding> RecordingDigest::allan_finding() const {
  if (!allan) return std::nullopt;
  return allan_finding_of(*allan);
}

std::string RecordingDigest::allan_warning() const {
  if (!allan) return allan_unavailable_warning(samples, allan_unavailable);
  return allan->gaps.too_much() ? recording.source + ": " + allan->gaps.warning() : "";
}

RecordingDigest digest_recording(const std::string& path, const DigestOptions& options) {
  RecordingDigester sink(options);
  Recording read = stream_recording(path, sink);
  return sink.finish(std::move(read));
}

bool is_stand_recording(const std::string& path) {
  // Only a regular file can be opened twice (here, then to read it); a pipe's first lines
  // would be gone, so it is read whole by the caller's other reader.
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) return false;
  LineSource lines = LineSource::of_file(path);
  std::string_view line;
  bool format_seen = false;
  while (lines.next(line)) {
    if (line.find_first_not_of(" \t") == std::string_view::npos) continue;
    if (line.front() == '#') {
      format_seen =
          format_seen || line.find("format: standcal-recording/") != std::string_view::npos;
      continue;
    }
    return format_seen && line.find("alpha1_cmd_deg") != std::string_view::npos &&
           line.find("alpha2_cmd_deg") != std::string_view::npos;
  }
  return false;
}

}  // namespace standcal
