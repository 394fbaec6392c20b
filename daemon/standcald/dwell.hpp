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

#include "calib/recording.hpp"
#include "daemon/standcald/config.hpp"
#include "drivers/accel_unit.hpp"

namespace standcal::daemon {

// Per-axis statistics of a position's samples (m/s^2; trend = drift over the dwell).
struct DwellAverage {
  std::array<double, 3> mean_mps2{};
  std::array<double, 3> sigma_mps2{};  // sample standard deviation (n - 1)
  std::array<double, 3> trend_mps2{};  // least-squares slope times the dwell's span
  double temp_mean_c = kNoValue;       // NaN when no sample carries a temperature
  std::size_t count = 0;
  double span_s = 0;  // first to last sample
};

DwellAverage average_dwell(const std::vector<drivers::AccelSample>& samples);

// What a dwell's samples were judged against.
struct DwellExpectation {
  std::string unit_name;          // named in the "no sample" message
  double dwell_s = 0;             // unit time sampled
  double sample_rate_hz = 0;      // the unit's configured rate
  std::uint64_t incomplete = 0;   // frames the unit reported incomplete during the dwell
  double g_local_mps2 = 9.80665;  // µg conversions
  // The unit's configured Gauss-Markov bias wander (unit.bias_instability_ug / _tau_s): part
  // of what explains a drift over the dwell.
  double bias_wander_ug = 0;
  double bias_wander_tau_s = 300;
};

// The standard deviation of a dwell's trend (least-squares slope times span) that noise
// explains: white noise of `residual_sigma` over `n` evenly spaced samples, plus a
// Gauss-Markov wander of stationary sigma `wander_sigma` and correlation time `tau_s` over
// `span_s` (same unit as the sigmas).
double explained_trend_sigma(double residual_sigma, std::size_t n, double span_s,
                             double wander_sigma, double tau_s);

// Why the dwell is not good enough to keep, in the operator's words, or empty when it is:
// no sample at all, fewer than `rule.min_sample_fraction` of the expected samples, an axis
// noisier than `sigma_limit_ug`, one that drifted more than `trend_limit_ug`, or (when
// `trend_limit_sigmas` is set) more than that many times what its noise explains.
std::string dwell_problem(const DwellAverage& dwell, const DwellExpectation& expected,
                          const StabilityRule& rule);

// "x", "y", "z".
std::string axis_name(int axis);

}  // namespace standcal::daemon
