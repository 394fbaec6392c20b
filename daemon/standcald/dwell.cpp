#include "daemon/standcald/dwell.hpp"

#include <spdlog/fmt/fmt.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

#include "calib/text.hpp"
#include "daemon/standcald/sequencer_detail.hpp"

namespace standcal::daemon {

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
      out.temp_min_c = std::fmin(out.temp_min_c, x.temperature_c);  // fmin passes NaN over
      out.temp_max_c = std::fmax(out.temp_max_c, x.temperature_c);
    }
  }
  if (temp_n > 0) out.temp_mean_c = temp_sum / temp_n;
  const double span = s.back().t_s - s.front().t_s;
  out.span_s = span;
  for (int a = 0; a < 3; ++a) {
    double mean = 0;
    for (const auto& x : s) {
      mean += x.force_mps2[a] / n;
      const double v = std::abs(x.force_mps2[a]);
      if (!(v <= out.max_abs_mps2[a])) out.max_abs_mps2[a] = v;  // NaN sticks
    }
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
    if (s.size() > 2 && stt > 0)
      out.residual_sigma_mps2[a] = std::sqrt(std::max(var - sty * sty / stt, 0.0) / (n - 2));
    if (a == 0 && stt > 0) out.trend_gain = span / std::sqrt(stt);
  }
  return out;
}

double wander_trend_sigma(double span_s, double wander_sigma, double tau_s) {
  if (!(wander_sigma > 0 && tau_s > 0 && span_s > 0)) return 0;
  // 144 q^2 I(x), x = span / tau, I(x) = the double integral over [0, 1]^2 of
  // (u - 1/2)(v - 1/2) e^(-x |u - v|) = 2 int_0^1 e^(-x d) g(d) dd with
  // g(d) = ((1/2 - d)^3 + 1/8) / 3 + d (d^2 - d) / 2 (the weights' overlap at lag d), by
  // Simpson's rule on a grid fine against 1 / x.
  const double x = span_s / tau_s;
  const auto g = [](double d) {
    const double c = 0.5 - d;
    return (c * c * c + 0.125) / 3 + d * (d * d - d) / 2;
  };
  const int steps = 2 * static_cast<int>(std::min(1e6, 500 + 16 * std::ceil(x)));
  const double h = 1.0 / steps;
  double sum = g(0) + std::exp(-x) * g(1);
  for (int i = 1; i < steps; ++i) sum += (i % 2 == 1 ? 4 : 2) * std::exp(-x * i * h) * g(i * h);
  const double integral = 2 * sum * h / 3;
  return wander_sigma * std::sqrt(std::max(144 * integral, 0.0));
}

double explained_trend_sigma_mps2(const DwellAverage& dwell, int axis, double wander_sigma_mps2,
                                  double tau_s, double correlation_widening) {
  // For samples correlated over a few periods the slope's variance, like the mean's, is the
  // long-run noise's: the independent samples' variance times the same factor squared, for
  // dwells long against the correlation.
  return std::hypot(dwell.residual_sigma_mps2[axis] * dwell.trend_gain * correlation_widening,
                    wander_trend_sigma(dwell.span_s, wander_sigma_mps2, tau_s));
}

DwellSampleCorrelation::DwellSampleCorrelation(double sample_period_s, double g_local_mps2)
    : sample_period_s_(sample_period_s),
      ug_per_mps2_(1e6 / g_local_mps2),
      allan_{AllanAccumulator(sample_period_s), AllanAccumulator(sample_period_s),
             AllanAccumulator(sample_period_s)} {}

std::array<double, 3> DwellSampleCorrelation::add_dwell(
    const std::vector<drivers::AccelSample>& samples, const DwellAverage& average) {
  pool(samples, average);
  return widening();
}

void DwellSampleCorrelation::pool(const std::vector<drivers::AccelSample>& samples,
                                  const DwellAverage& average) {
  if (samples.size() < 3) return;
  const double n = static_cast<double>(samples.size());
  double t_mean = 0;
  for (const auto& x : samples) t_mean += x.t_s / n;
  for (std::size_t a = 0; a < 3; ++a) {
    // The dwell's least-squares line: its trend is the slope times the span.
    const double slope_per_s = average.span_s > 0 ? average.trend_mps2[a] / average.span_s : 0.0;
    std::vector<double> about_line;  // ug
    about_line.reserve(samples.size() + 1);
    for (const auto& x : samples) {
      about_line.push_back(
          (x.force_mps2[a] - average.mean_mps2[a] - slope_per_s * (x.t_s - t_mean)) * ug_per_mps2_);
      scatter_ug2_[static_cast<Eigen::Index>(a)] += about_line.back() * about_line.back();
    }
    allan_[a].add_segment(about_line);  // consumes it
  }
  dof_ += n - 2;
}

std::array<double, 3> DwellSampleCorrelation::widening() const {
  std::array<double, 3> widening{1, 1, 1};
  if (!(dof_ > 0)) return widening;
  const std::optional<SampleCorrelation> correlation = sample_correlation(
      {allan_[0].curve(), allan_[1].curve(), allan_[2].curve()}, sample_period_s_);
  if (!correlation) return widening;
  const Vec3 factor = widening_factor(*correlation, (scatter_ug2_ / dof_).cwiseSqrt());
  for (int a = 0; a < 3; ++a) widening[static_cast<std::size_t>(a)] = factor[a];
  return widening;
}

namespace {

// Hands each position block of a recording to the pool as one dwell.
class DwellPoolSink final : public RecordingRowSink {
 public:
  explicit DwellPoolSink(DwellSampleCorrelation& pool) : pool_(pool) {}
  void header(const Recording& h) override { warmup_s_ = h.warmup_s; }
  void row(const RecordingSample& s) override {
    if (warm_up_row(s)) return;
    if (!dwell_.empty() && s.pos != pos_) flush();
    pos_ = s.pos;
    drivers::AccelSample x;
    x.t_s = s.t_s;
    for (int a = 0; a < 3; ++a) x.force_mps2[static_cast<std::size_t>(a)] = s.f_mps2[a];
    dwell_.push_back(x);
  }
  void flush() {
    if (dwell_.empty()) return;
    pool_.pool(dwell_, average_dwell(dwell_));
    dwell_.clear();
    ++dwells_;
  }
  std::size_t dwells() const { return dwells_; }

 private:
  // The run had left its warm-up out of the pool (a warm-up is where the unit settles):
  // position 0's rows within the header's warmup_s of its first (calib's warmup_end_s).
  bool warm_up_row(const RecordingSample& s) {
    if (!(warmup_s_ > 0) || s.pos != 0) return false;
    if (!warmup_end_s_) warmup_end_s_ = s.t_s + warmup_s_;
    return is_warmup_row(s, *warmup_end_s_);
  }

  DwellSampleCorrelation& pool_;
  double warmup_s_ = 0;
  std::optional<double> warmup_end_s_;
  std::vector<drivers::AccelSample> dwell_;
  int pos_ = 0;
  std::size_t dwells_ = 0;
};

}  // namespace

std::size_t DwellSampleCorrelation::add_recorded_dwells(const std::string& path) {
  DwellPoolSink sink(*this);
  (void)stream_recording(path, sink);
  sink.flush();
  return sink.dwells();
}

namespace {

// The drift of axis `a` against what its noise explains, or empty when within the rule
// (or when nothing explains any drift: a dwell without noise cannot be judged so).
std::string unexplained_drift(const DwellAverage& dwell, const DwellExpectation& expected,
                              const StabilityRule& rule, int a, double ug_per_mps2) {
  if (!(rule.trend_limit_sigmas > 0) || dwell.count < 3) return {};
  const double trend_ug = dwell.trend_mps2[a] * ug_per_mps2;
  const double widening = expected.sample_correlation_widening[static_cast<std::size_t>(a)];
  const double wander_ug = expected.bias_wander_ug[static_cast<std::size_t>(a)];
  const double explained_ug = explained_trend_sigma_mps2(dwell, a, wander_ug / ug_per_mps2,
                                                         expected.bias_wander_tau_s, widening) *
                              ug_per_mps2;
  if (!(explained_ug > 0)) return {};
  // The ratio said is the ratio judged.
  const double times_explained = std::abs(trend_ug) / explained_ug;
  if (!(times_explained > rule.trend_limit_sigmas)) return {};
  const auto [times, limit] = number_texts_apart(times_explained, rule.trend_limit_sigmas);
  return "axis " + axis_name(a) + " drifted " + number_text(trend_ug) + " µg during the dwell, " +
         times + " times what its noise explains (" + number_text(explained_ug) +
         " µg from its sample σ" +
         (widening > 1 ? fmt::format(" widened {:.3g} times for its correlated samples", widening)
                       : std::string()) +
         (wander_ug > 0 ? std::string(" and the unit's bias wander") : "") + "; limit " + limit +
         " times)";
}

}  // namespace

std::string implausible_reading(const DwellAverage& dwell) {
  for (int a = 0; a < 3; ++a)
    if (!is_plausible_accelerometer_value(dwell.max_abs_mps2[a]))
      return "axis " + axis_name(a) + " read " +
             number_texts_apart(dwell.max_abs_mps2[a], kMaxAbsAccelerometerValue).value +
             " m/s^2, beyond any accelerometer's output: check the unit's CAN layout (signal "
             "lengths, scale and offset)";
  for (const double temp_c : {dwell.temp_min_c, dwell.temp_max_c})
    if (std::isfinite(temp_c) && !is_plausible_temperature(temp_c))
      return "the unit's temperature read " +
             number_texts_apart(temp_c, temperature_bound_past_c(temp_c)).value +
             " degC, which no unit has (-273.15 ... 1000 degC): check the temperature signal "
             "of the unit's CAN layout (length, scale and offset)";
  return {};
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
  if (std::string wrong = implausible_reading(dwell); !wrong.empty()) return wrong;
  const double ug_per_mps2 = 1e6 / expected.g_local_mps2;
  for (int a = 0; a < 3; ++a) {
    const double sigma_ug = dwell.sigma_mps2[a] * ug_per_mps2;
    const double trend_ug = dwell.trend_mps2[a] * ug_per_mps2;
    if (sigma_ug > rule.sigma_limit_ug) {
      const auto [noise, limit] = number_texts_apart(sigma_ug, rule.sigma_limit_ug);
      return "axis " + axis_name(a) + " noise " + noise + " µg above the limit " + limit + " µg";
    }
    if (std::abs(trend_ug) > rule.trend_limit_ug) {
      const auto [trend, limit] = number_texts_apart(trend_ug, rule.trend_limit_ug);
      return "axis " + axis_name(a) + " drifted " + trend + " µg during the dwell (limit " + limit +
             " µg)";
    }
    if (std::string drift = unexplained_drift(dwell, expected, rule, a, ug_per_mps2);
        !drift.empty())
      return drift;
  }
  return {};
}

}  // namespace standcal::daemon
