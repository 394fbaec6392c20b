#pragma once
// The Allan deviation of any raw recording's static samples, in ug of the unit's axes: what
// `standcal noise` reads off a recording the raw reader takes (imu_tk text, delimited text,
// a standcal recording without angles), where a stand recording's dwells are pooled by
// calib/recording_digest instead. The static intervals (detected, or the recording's dwell
// blocks) are pooled as segments of one curve per axis, as the norm fit's coloured-noise
// standard errors are (calib/static_intervals.hpp): the longest stretch sets how far the
// curve reaches, and the short ones add terms at short averaging times.
#include <optional>
#include <string>

#include "calib/allan.hpp"
#include "calib/model.hpp"
#include "calib/raw_input.hpp"
#include "calib/static_intervals.hpp"

namespace standcal {

struct StaticNoiseOptions {
  StaticDetectorOptions detector;
  // Counts per g of every axis, for counts of a unit held in one orientation (the norm fit,
  // which finds the scale otherwise, needs several).
  std::optional<double> counts_per_g;
};

struct StaticNoise {
  DwellAllan allan;           // curves in ug, figures in ug/sqrt(Hz), ug and ug/sqrt(s)
  std::size_t samples = 0;    // static samples pooled
  double longest_s = 0;       // the longest static stretch
  std::string intervals_how;  // how the intervals were found (the detection's words)
  std::string units_how;      // how the input's units became ug, in words
  Vec3 ug_per_unit = Vec3::Ones();
};

// Throws std::runtime_error naming the source: a table of means (no samples), no static
// interval, too few static samples, or counts with neither --counts-per-g nor orientations
// enough for the norm fit to find the scale; std::invalid_argument for a counts_per_g given
// with values not read as counts.
StaticNoise static_noise(const RawInput& in, const StaticNoiseOptions& options = {});

// The pooled curves of a detection scaled per axis to ug, with the figures read off them and
// the time missing inside the intervals (`gaps`).
DwellAllan allan_in_ug(const StaticDetection& d, const Vec3& ug_per_unit, double sample_period_s);

}  // namespace standcal
