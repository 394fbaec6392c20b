#include "daemon/standcald/dwell.hpp"

#include <cmath>

#include "daemon/standcald/sequencer_detail.hpp"

namespace standcal::daemon {

using detail::number_text;

std::string axis_name(int axis) { return axis == 0 ? "x" : axis == 1 ? "y" : "z"; }

DwellAverage average_dwell(const std::vector<drivers::AccelSample>& s) {
  DwellAverage out;
  out.count = s.size();
  if (s.empty()) return out;
  const double n = static_cast<double>(s.size());
  double t_mean = 0, temp_sum = 0;
  int temp_n = 0;
  for (const auto& x : s) {
    t_mean += x.t_s / n;
    if (std::isfinite(x.temperature_c)) {
      temp_sum += x.temperature_c;
      ++temp_n;
    }
  }
  if (temp_n > 0) out.temp_mean_c = temp_sum / temp_n;
  const double span = s.back().t_s - s.front().t_s;
  for (int a = 0; a < 3; ++a) {
    double mean = 0;
    for (const auto& x : s) mean += x.force_mps2[a] / n;
    double var = 0, stt = 0, sty = 0;
    for (const auto& x : s) {
      const double d = x.force_mps2[a] - mean, dt = x.t_s - t_mean;
      var += d * d;
      stt += dt * dt;
      sty += dt * d;
    }
    out.mean_mps2[a] = mean;
    out.sigma_mps2[a] = s.size() > 1 ? std::sqrt(var / (n - 1)) : 0.0;
    out.trend_mps2[a] = stt > 0 ? sty / stt * span : 0.0;  // least-squares slope x dwell
  }
  return out;
}

std::string dwell_problem(const DwellAverage& dwell, const DwellExpectation& expected,
                          const StabilityRule& rule) {
  const double expected_count = expected.dwell_s * expected.sample_rate_hz;
  if (dwell.count == 0 && expected.incomplete == 0) {
    // A dwell shorter than the unit's silence timeout ends before the driver calls the
    // unit silent: say what the operator should check.
    return "no sample from the accelerometer unit " + expected.unit_name + " during the " +
           number_text(expected.dwell_s) + " s dwell (is it powered and on the bus?)";
  }
  if (dwell.count < 2 ||
      static_cast<double>(dwell.count) < rule.min_sample_fraction * expected_count) {
    return "only " + std::to_string(dwell.count) + " of " +
           std::to_string(static_cast<long>(expected_count)) + " expected samples (" +
           std::to_string(expected.incomplete) + " incomplete)";
  }
  const double ug_per_mps2 = 1e6 / expected.g_local_mps2;
  for (int a = 0; a < 3; ++a) {
    const double sigma_ug = dwell.sigma_mps2[a] * ug_per_mps2;
    const double trend_ug = dwell.trend_mps2[a] * ug_per_mps2;
    if (sigma_ug > rule.sigma_limit_ug) {
      return "axis " + axis_name(a) + " noise " + number_text(sigma_ug) + " µg above the limit " +
             number_text(rule.sigma_limit_ug) + " µg";
    }
    if (std::abs(trend_ug) > rule.trend_limit_ug) {
      return "axis " + axis_name(a) + " drifted " + number_text(trend_ug) +
             " µg during the dwell (limit " + number_text(rule.trend_limit_ug) + " µg)";
    }
  }
  return {};
}

}  // namespace standcal::daemon
