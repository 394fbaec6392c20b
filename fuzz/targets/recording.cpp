// The recording reader (calib/recording.hpp): arbitrary text as a standcal-recording/1
// file. Properties: a recording that was read holds no number beyond the reader's bounds
// (times, angles, forces, temperatures, the header's rate and settling time: a corrupted
// field is refused at its line, not read as a measurement), and it can be written and read
// back with the same samples (the daemon writes what the offline commands read).
#include <cmath>
#include <string>

#include "calib/recording.hpp"
#include "fuzz/targets/fuzz_support.hpp"
#include "fuzz/targets/targets.hpp"

namespace {

std::string rewrite(const standcal::Recording& rec) {
  std::string text = standcal::format_recording_header(rec);
  standcal::append_recording_rows(text, rec.columns, rec.samples);
  return text;
}

void check_round_trip(const standcal::Recording& first) {
  const std::string text = rewrite(first);
  standcal::Recording second;
  try {
    second = standcal::parse_recording(text, "fuzz-rewritten");
  } catch (const std::runtime_error& e) {
    standcal::fuzz::report_finding(
        std::string("recording: a recording that was read cannot be read back after "
                    "writing it: ") +
        e.what());
  }
  standcal::fuzz::require(
      second.samples.size() == first.samples.size(),
      "recording: writing and reading back changed the number of samples from " +
          std::to_string(first.samples.size()) + " to " + std::to_string(second.samples.size()));
  for (std::size_t i = 0; i < first.samples.size(); ++i)
    standcal::fuzz::require(
        second.samples[i].pos == first.samples[i].pos,
        "recording: writing and reading back changed pos of sample " + std::to_string(i));
}

void check_bounds(const standcal::Recording& rec) {
  using namespace standcal;
  for (std::size_t i = 0; i < rec.samples.size(); ++i) {
    const std::string wrong = implausible_sample_text(rec.samples[i]);
    fuzz::require(wrong.empty(), "recording: sample " + std::to_string(i) +
                                     " was read beyond the bounds: " + wrong);
  }
  fuzz::require(std::isnan(rec.sample_rate_hz) || is_plausible_sample_rate(rec.sample_rate_hz),
                "recording: a sample rate beyond the bounds was read");
  fuzz::require(std::isnan(rec.settle_s) || (rec.settle_s >= 0 && rec.settle_s <= kMaxAbsTime_s),
                "recording: a settling time beyond the bounds was read");
  fuzz::require(!rec.temp_ref_c || is_plausible_temperature(*rec.temp_ref_c),
                "recording: a reference temperature beyond the bounds was read");
}

}  // namespace

int standcal_fuzz_recording(const std::uint8_t* data, std::size_t size) {
  return standcal::fuzz::expect_only_runtime_errors("recording", [&] {
    const standcal::Recording rec =
        standcal::parse_recording(standcal::fuzz::as_text(data, size), "fuzz-input");
    check_bounds(rec);
    check_round_trip(rec);
  });
}
