#pragma once
// Static intervals of a raw recording: the stretches where the unit was held still, found
// from the samples alone (docs/calibration.md, "Recordings without angles").
//
// Detector: the motion statistic of sample i is the sum over the three axes of the sample
// variance in a centred window of `window_s` (at least three samples), each variance
// floored at the data's quantisation (step^2 / 12, the step the smallest change between
// successive samples). Its quiet level Q is read off the data: the 10th percentile of the
// statistic over the whole recording. White noise alone makes the window variance scatter
// around Q by a relative sqrt(2 / (w - 1)) per axis; real sensors scatter more, so the
// spread is measured too, in the quietest half of the windows below the median: the edge
// of the still windows is Q * exp(6 * s_log), s_log the MAD scale of log(statistic) there
// (the lower tail alone, so it understates the spread: about 3.5 standard deviations), and
// the threshold is twice the edge, so that half the threshold (the stability refit) still
// admits the still windows and twice it still stops at motion. That needs about a quarter
// of the recording still; with less, the quietest quarter is partly motion, and the
// threshold is capped at ten times Q. A run of static samples of at least `min_length_s`
// is an interval. `threshold_factor` scales the threshold.
//
// Samples at the converter's limits are flagged and excluded: for counts, the limit codes
// of the smallest 8..32-bit range (signed or unsigned) that holds the data; for physical
// units, three or more identical samples at an axis's extreme beyond 1.2 g (clipping).
#include <cstddef>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "calib/allan.hpp"
#include "calib/model.hpp"
#include "calib/raw_input.hpp"

namespace standcal {

struct StaticInterval {
  std::size_t begin = 0, end = 0;  // sample indices [begin, end)
  double t_start_s = 0, t_end_s = 0;
  std::size_t samples = 0;    // used (saturated ones excluded)
  Vec3 mean = Vec3::Zero();   // input units
  Vec3 sigma = Vec3::Zero();  // sample standard deviation, input units
  // Standard error of the mean: sigma / sqrt(n) if the noise were white, and the one the
  // recording's own noise implies: the same where the intervals' pooled Allan curves are
  // white noise's, else the curve at this interval's length, never smaller
  // (StaticDetection::standard_errors_how). `standard_error` is what a fit weights the mean
  // with: the curve's, less the share of a bias wander the fit weights for between the
  // intervals (the norm fit's errors_beside_wander), which would otherwise count twice.
  Vec3 white_standard_error = Vec3::Zero();
  Vec3 curve_standard_error = Vec3::Zero();
  Vec3 standard_error = Vec3::Zero();
  double mid_time_s() const { return 0.5 * (t_start_s + t_end_s); }
};

struct StaticDetectorOptions {
  double window_s = 1.0;          // window of the motion statistic (imu_tk: 101 samples at 100 Hz)
  double min_length_s = 2.0;      // shortest interval kept
  double threshold_factor = 1.0;  // multiplies the data-derived threshold
  // Standcal recordings already say which samples are static (their dwell blocks): use
  // them rather than detect.
  bool use_blocks = true;
  // A calibration needs the unit turned: a recording that never leaves its noise, or is
  // never still relative to its range, is refused. A noise analysis takes one orientation
  // held throughout (a wander may then span many times the noise) as it is.
  bool require_orientations = true;
};

// What the gap warnings (DwellGaps::warning) call the stretches a raw recording's samples
// are pooled from.
inline constexpr std::string_view kStaticIntervals = "static intervals";

struct StaticDetection {
  std::vector<StaticInterval> intervals;
  std::string how;  // in words: blocks or detector, window, threshold
  std::size_t window_samples = 0;
  double quiet_level = 0;  // Q, input units^2
  double threshold = 0;    // input units^2
  double threshold_factor = 1;
  std::size_t saturated_samples = 0;
  std::size_t short_runs_dropped = 0;  // still stretches shorter than min_length_s
  // The Allan deviation of the intervals pooled, per axis, input units: what the
  // coloured-noise standard errors are read from.
  std::array<std::vector<AllanPoint>, 3> allan;
  // A standcal recording's warm-up (RawInput::warmup_s): its rows [begin, end), pooled into
  // the curves (and counted in `gaps`) but no interval; empty without one.
  std::pair<std::size_t, std::size_t> warm_up{0, 0};
  // Time missing inside the intervals, from their samples' time stamps: those curves take the
  // samples as evenly spaced, so beyond kMaxDwellGapShare no wander is read off them.
  DwellGaps gaps;
  // How the intervals' standard errors were made, and why: sigma / sqrt(n) where the pooled
  // curves are white noise's, else the curve at each interval's length ("; less the share of
  // the bias wander ..." where the norm fit took its wander out: say_errors_beside_wander).
  std::string standard_errors_how;
};

// Throws std::runtime_error naming the source when the input has no samples, no rate, or
// is shorter than two windows.
StaticDetection detect_static_intervals(const RawInput& input,
                                        const StaticDetectorOptions& options = {});

// The standard error of a T-second mean from an Allan curve: the deviation at T (log-log
// interpolation; beyond the curve, its last point continued at the slope of its last factor
// of three in tau, clamped to white noise's -1/2 .. random walk's +1/2). Never below `white`.
double coloured_standard_error(const std::vector<AllanPoint>& curve, double duration_s,
                               double white);

}  // namespace standcal
