#pragma once
// One dwell's samples reduced to what the run keeps and judges: the per-axis mean, the
// sample σ and the drift over the dwell, and the stability rule that decides whether the
// position is re-measured. Pure functions: no hardware, no clock (tests/daemon's
// DwellAverage and DwellStability cases run them without a daemon).
#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "calib/allan.hpp"
#include "calib/recording.hpp"
#include "daemon/standcald/config.hpp"
#include "drivers/accel_unit.hpp"

namespace standcal::daemon {

// Per-axis statistics of a position's samples (m/s^2; trend = drift over the dwell).
struct DwellAverage {
  std::array<double, 3> mean_mps2{};
  std::array<double, 3> sigma_mps2{};    // sample standard deviation (n - 1)
  std::array<double, 3> trend_mps2{};    // least-squares slope times the dwell's span
  std::array<double, 3> max_abs_mps2{};  // the largest |sample| (NaN when one is NaN)
  double temp_mean_c = kNoValue;         // NaN when no sample carries a temperature
  double temp_min_c = kNoValue;          // the extremes of the samples' temperatures
  double temp_max_c = kNoValue;
  std::size_t count = 0;
  double span_s = 0;  // first to last sample
  // Sample standard deviation about the least-squares line (n - 2): the dwell's noise
  // without its drift.
  std::array<double, 3> residual_sigma_mps2{};
  // The trend's standard deviation per unit white-noise sigma: span / sqrt(sum (t - mean
  // t)^2), from the samples' own times (sqrt(12 (n - 1) / (n (n + 1))) when evenly spaced).
  double trend_gain = 0;
};

DwellAverage average_dwell(const std::vector<drivers::AccelSample>& samples);

// What a dwell's samples were judged against.
struct DwellExpectation {
  std::string unit_name;          // named in the "no sample" message
  double dwell_s = 0;             // unit time sampled
  double sample_rate_hz = 0;      // the unit's configured rate
  std::uint64_t incomplete = 0;   // frames the unit reported incomplete during the dwell
  double g_local_mps2 = 9.80665;  // µg conversions
  // The unit's configured Gauss-Markov bias wander (unit.bias_instability_ug / _tau_s, or each
  // axis's from unit.static_recording): part of what explains a drift over the dwell.
  std::array<double, 3> bias_wander_ug{0, 0, 0};
  double bias_wander_tau_s = 300;
  // What the dwell's white noise is widened by per axis for its samples' own correlation
  // (DwellSampleCorrelation): a drift's scatter grows with it as a mean's error does.
  std::array<double, 3> sample_correlation_widening{1, 1, 1};
};

// The samples' own correlation (a unit's output filter: calib/allan.hpp, SampleCorrelation)
// over a run's dwells pooled as they are measured: consecutive correlated samples make a
// dwell's trend scatter more than its samples' sigma says, by the factor its mean's error is
// widened by (the same long-run noise drives both: 2.0 for a filter of two sample periods).
// The same short-correlation fit as the stand fits' (calib/averaging.hpp), on each dwell's
// samples about its own line: a drift, or a dwell re-measured for one, is not the unit's noise,
// and a re-measured dwell still shows the correlation (the fits pool the kept dwells about
// their means). One dwell of 250 samples shows a correlation less surely than the run's
// dwells pooled.
class DwellSampleCorrelation {
 public:
  DwellSampleCorrelation(double sample_period_s, double g_local_mps2);
  // Pools one dwell's samples (`average` is their average_dwell: its mean and trend are the
  // line taken out) and says, per axis, what a dwell's white noise is to be widened by: 1
  // where the pooled curves show no short correlation or are too short to fit
  // (calib/allan.hpp, sample_correlation).
  std::array<double, 3> add_dwell(const std::vector<drivers::AccelSample>& samples,
                                  const DwellAverage& average);
  // The same without the widening (its Allan fit), for dwells pooled in bulk.
  void pool(const std::vector<drivers::AccelSample>& samples, const DwellAverage& average);
  // Pools each position's samples of a recording file (a resumed run's dwells so far) and
  // says how many; throws what stream_recording throws.
  std::size_t add_recorded_dwells(const std::string& path);
  // The widening of the dwells pooled so far.
  std::array<double, 3> widening() const;

 private:
  double sample_period_s_;
  double ug_per_mps2_;
  std::array<AllanAccumulator, 3> allan_;
  Vec3 scatter_ug2_ = Vec3::Zero();  // sum over dwells of (n - 2) sigma^2 about their lines
  double dof_ = 0;
};

// The standard deviation of the trend (least-squares slope times span) that a Gauss-Markov
// wander of stationary sigma `wander_sigma` and correlation time `tau_s` gives a dwell of
// `span_s` (same unit as the sigma): 12 q^2 T / (5 tau) for a wander slow against the dwell,
// 24 q^2 tau / T for a fast one.
double wander_trend_sigma(double span_s, double wander_sigma, double tau_s);

// What noise explains of axis `axis`'s trend: its residual white noise through the trend
// gain, widened by `correlation_widening` for samples correlated among themselves, and the
// wander (same unit as `wander_sigma_mps2`).
double explained_trend_sigma_mps2(const DwellAverage& dwell, int axis, double wander_sigma_mps2,
                                  double tau_s, double correlation_widening);

// The axis whose samples no accelerometer gives (beyond calib's kMaxAbsAccelerometerValue),
// or a temperature no unit has (calib's is_plausible_temperature): a wrong CAN layout, not a
// unit, in the operator's words; empty when none. Such a dwell is neither kept (the readers
// refuse its rows) nor pooled into the run's noise statistics.
std::string implausible_reading(const DwellAverage& dwell);

// Why the dwell is not good enough to keep, in the operator's words, or empty when it is:
// no sample at all, fewer than `rule.min_sample_fraction` of the expected samples, an axis
// noisier than `sigma_limit_ug`, one that drifted more than `trend_limit_ug`, or (when
// `trend_limit_sigmas` is set) more than that many times what its noise explains.
std::string dwell_problem(const DwellAverage& dwell, const DwellExpectation& expected,
                          const StabilityRule& rule);

// "x", "y", "z".
std::string axis_name(int axis);

}  // namespace standcal::daemon
