#include "calib/static_intervals.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>

#include "calib/recording.hpp"
#include "calib/text.hpp"

namespace standcal {

namespace {

constexpr double kMaxThresholdOverQuiet = 10;

double quantile_of(std::vector<double> v, double p) {
  if (v.empty()) return kNaN;
  const auto k = static_cast<std::ptrdiff_t>(p * static_cast<double>(v.size() - 1));
  std::nth_element(v.begin(), v.begin() + k, v.end());
  return v[static_cast<std::size_t>(k)];
}

// Sum over the axes of the variance in the window centred on each sample (windows are
// clipped at the ends), from running sums of the samples less a reference (precision).
std::vector<double> motion_statistic(const RawInput& in, std::size_t w, double variance_floor) {
  const std::size_t n = in.size();
  std::vector<double> stat(n, 0.0);
  for (int a = 0; a < 3; ++a) {
    const std::vector<double>& x = in.axis[static_cast<std::size_t>(a)];
    const double ref = x.front();
    std::vector<double> s1(n + 1, 0.0), s2(n + 1, 0.0);
    for (std::size_t i = 0; i < n; ++i) {
      const double d = x[i] - ref;
      s1[i + 1] = s1[i] + d;
      s2[i + 1] = s2[i] + d * d;
    }
    const std::size_t half = w / 2;
    for (std::size_t i = 0; i < n; ++i) {
      const std::size_t lo = i >= half ? i - half : 0, hi = std::min(n, i + half + 1);
      const double m = static_cast<double>(hi - lo);
      const double mean = (s1[hi] - s1[lo]) / m;
      stat[i] += std::max(variance_floor, (s2[hi] - s2[lo]) / m - mean * mean) * m / (m - 1);
    }
  }
  return stat;
}

// Full scale of the smallest 8..32-bit converter range, signed or unsigned, that holds
// every value of the input; {0, 0} when the data fit none (not counts of a converter).
std::pair<double, double> converter_range(const RawInput& in) {
  double lo = in.axis[0].front(), hi = lo;
  for (const auto& x : in.axis)
    for (double v : x) lo = std::min(lo, v), hi = std::max(hi, v);
  for (int bits : {8, 10, 12, 14, 16, 18, 20, 24, 32}) {
    const double full = std::ldexp(1.0, bits);
    if (lo >= 0 && hi <= full - 1) return {0, full - 1};
    if (lo >= -full / 2 && hi <= full / 2 - 1) return {-full / 2, full / 2 - 1};
  }
  return {0, 0};
}

// Samples at the converter's limits: see the header.
std::vector<bool> saturated_samples(const RawInput& in, double g_in_input_units) {
  const std::size_t n = in.size();
  std::vector<bool> sat(n, false);
  if (in.units == InputUnits::counts) {
    const auto [lo, hi] = converter_range(in);
    if (hi <= lo) return sat;
    for (const auto& x : in.axis)
      for (std::size_t i = 0; i < n; ++i)
        if (x[i] <= lo || x[i] >= hi) sat[i] = true;
    return sat;
  }
  // Physical units: a run of three or more identical samples at an axis's extreme, beyond
  // 1.2 g (a unit at rest never reads more than 1 g on one axis; quantised exports repeat
  // values, clipping holds them at the range).
  for (const auto& x : in.axis) {
    const auto [mn, mx] = std::minmax_element(x.begin(), x.end());
    for (double limit : {*mn, *mx}) {
      if (std::abs(limit) < 1.2 * g_in_input_units) continue;
      for (std::size_t i = 0; i + 2 < n; ++i)
        if (x[i] == limit && x[i + 1] == limit && x[i + 2] == limit)
          sat[i] = sat[i + 1] = sat[i + 2] = true;
    }
  }
  return sat;
}

// The smallest step between successive samples of any axis: the converter's or the
// export's resolution, whose quantisation noise (step^2 / 12) floors every variance.
double quantisation_step(const RawInput& in) {
  double step = std::numeric_limits<double>::infinity();
  for (const auto& x : in.axis)
    for (std::size_t i = 1; i < x.size(); ++i)
      if (const double d = std::abs(x[i] - x[i - 1]); d > 0) step = std::min(step, d);
  return std::isfinite(step) ? step : 0;
}

// The quietest tenth of the windows must be still: their standard deviation well below the
// signal's own range (1 %: a unit whose noise is a percent of gravity cannot be calibrated
// to any use), and the signal must change orientation at all.
void require_still_somewhere(const RawInput& in, double quiet_level) {
  double half_range = 0;
  for (const auto& x : in.axis) {
    const auto [mn, mx] = std::minmax_element(x.begin(), x.end());
    half_range = std::max(half_range, (*mx - *mn) / 2);
  }
  const double quiet_sd = std::sqrt(quiet_level / 3);
  char what[200];
  if (half_range <= 10 * quiet_sd) {
    std::snprintf(what, sizeof what,
                  "the signal never leaves its noise (range +-%.3g against a noise of %.3g): one "
                  "orientation only",
                  half_range, quiet_sd);
    throw std::runtime_error(in.source + ": no static intervals to calibrate from: " + what);
  }
  if (quiet_sd > 0.01 * half_range) {
    std::snprintf(
        what, sizeof what,
        "even its quietest tenth varies by %.3g per sample, %.1f %% of the signal's range",
        quiet_sd, 100 * quiet_sd / half_range);
    throw std::runtime_error(in.source + ": no static interval found: the unit was never still (" +
                             what + ")");
  }
}

// Threshold of the motion statistic from its own distribution (see the header).
std::pair<double, double> quiet_level_and_threshold(const std::vector<double>& stat) {
  const double quiet = quantile_of(stat, 0.10);
  if (!(quiet > 0)) return {quiet, quiet};
  const double median = quantile_of(stat, 0.5);
  std::vector<double> logs;
  for (double s : stat)
    if (s > 0 && s <= median) logs.push_back(std::log(s));
  std::sort(logs.begin(), logs.end());
  logs.resize(logs.size() / 2 + 1);  // the quietest half of the windows below the median
  const double centre = quantile_of(logs, 0.5);
  std::vector<double> dev;
  for (double l : logs) dev.push_back(std::abs(l - centre));
  const double s_log = 1.4826 * quantile_of(dev, 0.5);
  // The edge of the still windows' own scatter (6 robust-scale units of log), and the
  // threshold twice that: the refit at half the threshold is then still a meaningful one.
  // A recording that is mostly motion makes the quietest quarter partly motion and the
  // scale meaningless: a still window's variance never exceeds ten times the quiet level.
  return {quiet, std::min(2 * quiet * std::exp(6.0 * s_log), kMaxThresholdOverQuiet * quiet)};
}

StaticInterval summarise(const RawInput& in, std::size_t begin, std::size_t end,
                         const std::vector<bool>& saturated, double sigma_floor) {
  StaticInterval iv;
  iv.begin = begin;
  iv.end = end;
  iv.t_start_s = in.t_s[begin];
  iv.t_end_s = in.t_s[end - 1];
  Vec3 sum = Vec3::Zero(), sum2 = Vec3::Zero();
  const Vec3 ref = in.sample(begin);
  for (std::size_t i = begin; i < end; ++i) {
    if (saturated[i]) continue;
    const Vec3 d = in.sample(i) - ref;
    sum += d;
    sum2 += d.cwiseProduct(d);
    ++iv.samples;
  }
  const double n = static_cast<double>(iv.samples);
  iv.mean = ref + sum / n;
  const Vec3 centred = sum / n;
  iv.sigma = ((sum2 / n - centred.cwiseProduct(centred)) * n / std::max(1.0, n - 1))
                 .cwiseMax(0.0)
                 .cwiseSqrt()
                 .cwiseMax(sigma_floor);
  iv.white_standard_error = iv.sigma / std::sqrt(n);
  iv.curve_standard_error = iv.standard_error = iv.white_standard_error;
  return iv;
}

// Runs of static, unsaturated samples at least min_samples long.
std::vector<std::pair<std::size_t, std::size_t>> static_runs(const std::vector<double>& stat,
                                                             double threshold,
                                                             std::size_t min_samples,
                                                             std::size_t& short_runs) {
  std::vector<std::pair<std::size_t, std::size_t>> runs;
  std::size_t i = 0;
  const std::size_t n = stat.size();
  while (i < n) {
    if (!(stat[i] <= threshold)) {  // moving, or not a number: never static
      ++i;
      continue;
    }
    std::size_t j = i;
    while (j < n && stat[j] <= threshold) ++j;
    if (j - i >= min_samples)
      runs.emplace_back(i, j);
    else
      ++short_runs;
    i = j;
  }
  return runs;
}

// The recording's dwell blocks; block 0's warm-up rows (RawInput::warmup_s) go to `warm_up`
// instead, as the stand averaging leaves them out of that position's mean.
std::vector<std::pair<std::size_t, std::size_t>> block_runs(
    const RawInput& in, std::pair<std::size_t, std::size_t>& warm_up) {
  std::vector<std::pair<std::size_t, std::size_t>> runs;
  std::size_t begin = 0;
  for (std::size_t i = 1; i <= in.size(); ++i)
    if (i == in.size() || in.block[i] != in.block[begin]) {
      std::size_t measured = begin;
      if (in.block[begin] == 0 && in.warmup_s > 0)
        while (measured < i && in.t_s[measured] < in.t_s[begin] + in.warmup_s) ++measured;
      if (measured > begin) warm_up = {begin, measured};
      if (measured < i) runs.emplace_back(measured, i);
      begin = i;
    }
  return runs;
}

// The stretches pooled into the curves: the warm-up (if any), then every interval.
std::vector<std::pair<std::size_t, std::size_t>> pooled_stretches(const StaticDetection& d) {
  std::vector<std::pair<std::size_t, std::size_t>> out;
  if (d.warm_up.second > d.warm_up.first) out.push_back(d.warm_up);
  for (const StaticInterval& iv : d.intervals) out.emplace_back(iv.begin, iv.end);
  return out;
}

// Whether the pooled curves are white noise's: white noise alone describes them, with
// neither a wander nor a short correlation beating it (fit_gauss_markov_allan's bars). A
// mean's error read off a curve at the interval's length is then σ/√n plus the scatter of
// the curve's last, few-cluster points, taken only upwards (never below white): on
// diagnostic32's white dwells that widened the errors by 15 % in variance on average, and
// the norm fit's sigmas with them (bench/noise, 2026-12-05).
bool curves_are_white(const StaticDetection& d, double period_s, std::string& why) {
  const std::optional<GaussMarkovAllanFit> fit =
      fit_gauss_markov_allan({d.allan[0], d.allan[1], d.allan[2]}, period_s);
  if (!fit) {
    why = "the pooled curves are too short to test against white noise";
    return false;
  }
  std::vector<std::string> reasons;
  if (fit->short_correlation) reasons.emplace_back("the samples are correlated over a few periods");
  if (fit->wander_seen) reasons.emplace_back("the pooled curves show a wander");
  if (!fit->describes_curves)
    reasons.emplace_back("the pooled curves depart from white noise and one correlation time");
  if (reasons.empty()) {
    why = "the pooled Allan curves are white noise's";
    return true;
  }
  why = reasons.front();
  for (std::size_t k = 1; k < reasons.size(); ++k) why += "; " + reasons[k];
  return false;
}

// The time missing inside the pooled stretches: each step between their samples against the
// rate.
DwellGaps interval_gaps(const RawInput& in, const StaticDetection& d) {
  DwellGaps gaps;
  const double period_s = 1.0 / in.sample_rate_hz;
  for (const auto& [begin, end] : pooled_stretches(d))
    for (std::size_t i = begin + 1; i < end; ++i)
      gaps.add_step(in.t_s[i] - in.t_s[i - 1], period_s);
  return gaps;
}

// The coloured-noise standard errors: the intervals pooled as segments of one Allan curve.
void attach_coloured_errors(const RawInput& in, StaticDetection& d) {
  std::array<std::vector<std::vector<double>>, 3> segments;
  for (const auto& [begin, end] : pooled_stretches(d))
    for (std::size_t a = 0; a < 3; ++a)
      segments[a].emplace_back(in.axis[a].begin() + static_cast<std::ptrdiff_t>(begin),
                               in.axis[a].begin() + static_cast<std::ptrdiff_t>(end));
  const double period = 1.0 / in.sample_rate_hz;
  for (std::size_t a = 0; a < 3; ++a) d.allan[a] = overlapping_allan_deviation(segments[a], period);
  std::string why;
  if (curves_are_white(d, period, why)) {
    d.standard_errors_how = "sigma / sqrt(n): " + why;
    return;
  }
  d.standard_errors_how = "the Allan deviation at each interval's length: " + why;
  for (StaticInterval& iv : d.intervals) {
    const double duration = static_cast<double>(iv.samples) * period;
    for (int a = 0; a < 3; ++a)
      iv.curve_standard_error[a] = coloured_standard_error(d.allan[static_cast<std::size_t>(a)],
                                                           duration, iv.white_standard_error[a]);
    iv.standard_error = iv.curve_standard_error;
  }
}

// The log-log slope of the curve's last factor of three in tau (least squares), between
// white noise's -1/2 and random walk's +1/2: how the deviation goes on beyond the curve.
double tail_slope(const std::vector<AllanPoint>& curve) {
  double sx = 0, sy = 0, sxx = 0, sxy = 0, n = 0;
  for (auto it = curve.rbegin(); it != curve.rend() && it->tau_s >= curve.back().tau_s / 3; ++it) {
    const double x = std::log(it->tau_s), y = std::log(it->deviation);
    sx += x, sy += y, sxx += x * x, sxy += x * y, n += 1;
  }
  if (n < 2) return 0;
  const double slope = (n * sxy - sx * sy) / (n * sxx - sx * sx);
  return std::clamp(slope, -0.5, 0.5);
}

}  // namespace

double coloured_standard_error(const std::vector<AllanPoint>& curve, double duration_s,
                               double white) {
  if (curve.empty() || !(duration_s > 0)) return white;
  double value = 0;
  if (duration_s <= curve.front().tau_s) {
    value = curve.front().deviation * std::sqrt(curve.front().tau_s / duration_s);
  } else if (duration_s >= curve.back().tau_s) {
    value = curve.back().deviation * std::pow(duration_s / curve.back().tau_s, tail_slope(curve));
  } else {
    std::size_t k = 1;
    while (curve[k].tau_s < duration_s) ++k;
    const AllanPoint& p = curve[k - 1];
    const AllanPoint& q = curve[k];
    const double f = std::log(duration_s / p.tau_s) / std::log(q.tau_s / p.tau_s);
    value = std::exp(std::log(p.deviation) + f * std::log(q.deviation / p.deviation));
  }
  return std::max(white, value);
}

StaticDetection detect_static_intervals(const RawInput& in, const StaticDetectorOptions& o) {
  if (in.size() == 0)
    throw std::runtime_error(in.source + ": no samples to find static intervals in");
  if (!(in.sample_rate_hz > 0))
    throw std::runtime_error(in.source + ": no sample rate (give " + in.option("rate-hz") + ")");
  if (!is_plausible_sample_rate(in.sample_rate_hz))  // the readers refuse it; windows overflow
    throw std::runtime_error(in.source + ": " +
                             implausible_sample_rate_text(round_trip_text(in.sample_rate_hz)));
  StaticDetection d;
  d.threshold_factor = o.threshold_factor;
  const double g_in_input = in.units == InputUnits::g ? 1.0 : in.g_mps2;
  const std::vector<bool> saturated = saturated_samples(in, g_in_input);
  const double step = quantisation_step(in);
  const double quantisation_variance = step * step / 12;
  d.saturated_samples =
      static_cast<std::size_t>(std::count(saturated.begin(), saturated.end(), true));
  std::vector<std::pair<std::size_t, std::size_t>> runs;
  char how[256];
  if (o.use_blocks && !in.block.empty()) {
    runs = block_runs(in, d.warm_up);
    std::snprintf(how, sizeof how, "the recording's %zu dwell blocks (no detection)%s", runs.size(),
                  d.warm_up.second > d.warm_up.first ? ", its warm-up in the curves alone" : "");
  } else {
    // Odd, and at least three samples: a variance needs two, centring one more.
    d.window_samples = std::max<std::size_t>(
        3, static_cast<std::size_t>(std::lround(o.window_s * in.sample_rate_hz)) | 1u);
    if (in.size() < 2 * d.window_samples)
      throw std::runtime_error(in.source + ": " + std::to_string(in.size()) +
                               " samples are fewer than two detector windows");
    std::vector<double> stat = motion_statistic(in, d.window_samples, quantisation_variance);
    std::tie(d.quiet_level, d.threshold) = quiet_level_and_threshold(stat);
    if (o.require_orientations) require_still_somewhere(in, d.quiet_level);
    d.threshold *= o.threshold_factor;
    for (std::size_t i = 0; i < stat.size(); ++i)
      if (saturated[i]) stat[i] = d.threshold * 2 + 1;  // never static
    const auto min_samples =
        static_cast<std::size_t>(std::ceil(o.min_length_s * in.sample_rate_hz));
    runs =
        static_runs(stat, d.threshold, std::max<std::size_t>(min_samples, 2), d.short_runs_dropped);
    std::snprintf(how, sizeof how,
                  "detector: %zu-sample window variance below %.4g (quiet level %.4g x %.3g, "
                  "threshold factor %.3g), at least %.3g s",
                  d.window_samples, d.threshold, d.quiet_level,
                  d.threshold / d.quiet_level / o.threshold_factor, o.threshold_factor,
                  o.min_length_s);
  }
  d.how = how;
  for (const auto& [b, e] : runs) {
    StaticInterval iv = summarise(in, b, e, saturated, std::sqrt(quantisation_variance));
    if (iv.samples >= 2) d.intervals.push_back(iv);
  }
  attach_coloured_errors(in, d);
  d.gaps = interval_gaps(in, d);
  return d;
}

}  // namespace standcal
