#pragma once
// Reduces a recording to one PositionAverage per position block.
//
// Outlier rule (why: a single glitch sample must not move a position's mean): per axis,
// the robust scale s = 1.4826 * MAD around the median (floored at 1 µg, so noise-free or
// coarsely quantised data never rejects ordinary samples); a sample further than
// kOutlierThreshold * s from the median on ANY axis is dropped on all axes and counted.
// Gaussian noise loses 2e-9 of its samples to this rule, a glitch is always removed.
#include <array>
#include <cstddef>
#include <optional>
#include <vector>

#include "calib/allan.hpp"
#include "calib/position_average.hpp"
#include "calib/recording.hpp"

namespace standcal {

inline constexpr double kOutlierThreshold = 6.0;
inline constexpr double kRobustScaleFloor_g = 1e-6;  // 1 µg

// One dwell's rows as columns: what its average needs, and nothing per row it does not.
struct DwellSamples {
  RecordingSample head;  // the first row: pos, commanded angles, mount, arrival, approach
  double t_end_s = 0;
  std::array<std::vector<double>, 3> f_mps2;
  std::vector<double> temp_c;  // NaN where not measured; empty unless with_temperature
  bool with_temperature = true;
  // The recording's warm-up (Recording::warmup_s): position 0's rows within it of its first
  // are counted here, at the front of the columns, and left out of its average.
  double warmup_s = 0;
  std::size_t warmup_samples = 0;
  double measured_from_s = 0;  // the first row after the warm-up

  std::size_t size() const { return f_mps2[0].size(); }
  // Whether `s`, the block's next row, is its warm-up's: the front of position 0's block,
  // within warmup_s of its first row (once a row is measured, none after it is).
  bool warm_up_row(const RecordingSample& s) const {
    return warmup_s > 0 && s.pos == 0 && size() == warmup_samples &&
           (size() == 0 || s.t_s < head.t_s + warmup_s);
  }
  // Whether `s` is the first measured row after a warm-up (the step to it is no period).
  bool ends_warm_up(const RecordingSample& s) const {
    return warmup_samples > 0 && size() == warmup_samples && !warm_up_row(s);
  }
  void clear();
  void add(const RecordingSample& s);
  void reserve(std::size_t rows);
};

// The average of one dwell, with the recording's g, settle time and default mount; a
// warm-up's rows left out (its mean, errors and times are the measured rows'). Its
// approach is the row's `approach` column, 0 when absent (see derive_missing_approaches).
// Throws std::runtime_error naming the recording when fewer than 2 samples are usable.
PositionAverage average_dwell(const DwellSamples& dwell, const Recording& header);
// Gives each average whose recording carried no approach the model.md rule's direction.
void derive_missing_approaches(std::vector<PositionAverage>& averages);

// Per-position means, standard errors, counts, approach and arrival of a recording. The
// standard errors are sigma / sqrt(n) widened by the samples' own correlation where the
// dwells' pooled Allan curves show one (widen_for_sample_correlation).
// Throws std::runtime_error naming the recording if it has no samples, or a position
// keeps fewer than 2 samples after outlier rejection.
std::vector<PositionAverage> average_positions(const Recording& rec);
// The same averages with the Allan figures of the recording's dwells pooled (the fits'
// `noise.allan`; nothing where it has too few samples or no sample rate), whose
// sample_correlation, where there is one, carries the factor the errors were widened by.
struct AveragedRecording {
  std::vector<PositionAverage> averages;
  std::optional<AllanFinding> allan;
  // allan_unavailable_warning's text when the recording has no curve, its gaps' (DwellGaps)
  // when they hold too much of the dwells' time, or "".
  std::string allan_warning;
};
AveragedRecording average_recording(const Recording& rec);

// Multiplies each mean's standard error by the samples' own correlation's factor (a unit's
// output filter: calib/allan.hpp, SampleCorrelation): sigma / sqrt(n) takes the samples of
// a dwell as independent, and correlated ones average down more slowly. The factor, per
// axis, is the white noise a dwell mean sees over sigma sqrt(tau0), sigma the averages' own
// sample deviations pooled (n - 1 each, outliers left out as in the means); it is stored in
// `correlation`.
void widen_for_sample_correlation(std::vector<PositionAverage>& averages,
                                  SampleCorrelation& correlation);

// How much a dwell mean's standard error exceeds sigma / sqrt(n): the widening for correlated
// samples, 1 where there is none. What one sample's sigma is to be widened by in a test that
// spans the dwell as its mean does.
double correlation_widening(const PositionAverage& a, int axis);

// The unit's mean temperature over the dwells that have one, or nothing: the temperature a
// calibration holds at.
std::optional<double> mean_dwell_temperature_c(const std::vector<PositionAverage>& averages);

// The approach direction into each of a sequence of commanded positions (model.md
// hysteresis rule): the sign of the move on the axis with the larger |delta alpha|,
// ties to alpha1, the first move from (0, 0), no move gives +1.
std::vector<int> approach_directions(const std::vector<std::pair<double, double>>& alpha_cmd_deg);

}  // namespace standcal
