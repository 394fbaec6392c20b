#include "calib/allan.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "calib/units.hpp"

namespace standcal {

AllanAccumulator::AllanAccumulator(double sample_period_s, int points_per_decade)
    : sample_period_s_(sample_period_s), points_per_decade_(points_per_decade) {
  if (!(sample_period_s > 0))
    throw std::invalid_argument("Allan deviation: the sample period must be positive");
  if (points_per_decade < 1)
    throw std::invalid_argument("Allan deviation: points per decade must be >= 1");
}

void AllanAccumulator::extend_cluster_sizes(long max_m) {
  while (cluster_sizes_.empty() || cluster_sizes_.back() < max_m) {
    const double exponent = static_cast<double>(next_exponent_step_) / points_per_decade_;
    const long m = std::lround(std::pow(10.0, exponent));
    if (m > max_m) return;
    ++next_exponent_step_;
    if (!cluster_sizes_.empty() && m == cluster_sizes_.back()) continue;
    cluster_sizes_.push_back(m);
    sum_sq_.push_back(0.0);
    terms_.push_back(0);
  }
}

void AllanAccumulator::add_segment(std::vector<double>& samples) {
  const std::size_t sample_count = samples.size();
  // Phase x_k = tau0 * (sum of the first k samples), k = 0..n, in place.
  double running = 0;
  for (double& v : samples) {
    const double sample = v;
    v = running;
    running += sample * sample_period_s_;
  }
  samples.push_back(running);
  const double* x = samples.data();
  const long n = static_cast<long>(samples.size());
  extend_cluster_sizes(n / 2);
  std::vector<double> sums;
  for (std::size_t i = 0; i < cluster_sizes_.size(); ++i) {
    const long m = cluster_sizes_[i];
    const long count = n - 2 * m;  // second differences x[k+2m] - 2 x[k+m] + x[k], k < count
    if (count <= 0) break;
    double partial[4] = {0, 0, 0, 0};
    long k = 0;
    for (; k + 4 <= count; k += 4)
      for (int j = 0; j < 4; ++j) {
        const double d = x[k + j + 2 * m] - 2 * x[k + j + m] + x[k + j];
        partial[j] += d * d;
      }
    for (; k < count; ++k) {
      const double d = x[k + 2 * m] - 2 * x[k + m] + x[k];
      partial[0] += d * d;
    }
    sums.push_back((partial[0] + partial[1]) + (partial[2] + partial[3]));
  }
  add_sums(n, sample_count, sums);
  if (keep_segment_sums_) kept_.push_back({n, std::move(sums)});
}

void AllanAccumulator::add_sums(long phase_length, std::size_t samples,
                                const std::vector<double>& sums) {
  ++segments_;
  longest_ = std::max(longest_, samples);
  extend_cluster_sizes(phase_length / 2);
  for (std::size_t i = 0; i < sums.size(); ++i) {
    sum_sq_[i] += sums[i];
    terms_[i] += phase_length - 2 * cluster_sizes_[i];
  }
}

void AllanAccumulator::append(const AllanAccumulator& later) {
  if (later.sample_period_s_ != sample_period_s_ || later.points_per_decade_ != points_per_decade_)
    throw std::invalid_argument("Allan deviation: appending segments of another sampling");
  if (later.segments_ != later.kept_.size())
    throw std::logic_error("Allan deviation: append needs every segment's sums kept");
  for (const SegmentSums& s : later.kept_)
    add_sums(s.phase_length, static_cast<std::size_t>(s.phase_length - 1), s.sums);
}

std::vector<AllanPoint> AllanAccumulator::curve() const {
  std::vector<AllanPoint> curve;
  const long max_m = static_cast<long>(longest_ / 3);
  for (std::size_t i = 0; i < cluster_sizes_.size(); ++i) {
    if (cluster_sizes_[i] > max_m) break;
    if (terms_[i] == 0) continue;
    const double tau = static_cast<double>(cluster_sizes_[i]) * sample_period_s_;
    curve.push_back({tau,
                     std::sqrt(sum_sq_[i] / (2.0 * tau * tau * static_cast<double>(terms_[i]))),
                     terms_[i]});
  }
  return curve;
}

std::vector<AllanPoint> overlapping_allan_deviation(
    const std::vector<std::vector<double>>& segments, double sample_period_s,
    int points_per_decade) {
  AllanAccumulator pooled(sample_period_s, points_per_decade);
  for (const auto& s : segments) {
    std::vector<double> segment = s;
    pooled.add_segment(segment);
  }
  return pooled.curve();
}

namespace {

// Local log-log slope at point i (central where possible).
double local_slope(const std::vector<AllanPoint>& c, std::size_t i) {
  const std::size_t a = i == 0 ? 0 : i - 1;
  const std::size_t b = std::min(i + 1, c.size() - 1);
  if (a == b) return 0;
  return std::log(c[b].deviation / c[a].deviation) / std::log(c[b].tau_s / c[a].tau_s);
}

}  // namespace

NoiseFigures noise_figures(const std::vector<AllanPoint>& curve) {
  NoiseFigures f;
  if (curve.size() < 3) return f;
  std::size_t i_min = 0;
  for (std::size_t i = 1; i < curve.size(); ++i)
    if (curve[i].deviation < curve[i_min].deviation) i_min = i;
  // Slope -1/2 region, before the minimum: average log(sigma * sqrt(tau)) = log N.
  double sum_white = 0, sum_rw = 0;
  int n_white = 0, n_rw = 0;
  for (std::size_t i = 0; i < curve.size(); ++i) {
    const double s = local_slope(curve, i);
    if (i <= i_min && std::abs(s + 0.5) < 0.15) {
      sum_white += std::log(curve[i].deviation * std::sqrt(curve[i].tau_s));
      ++n_white;
    }
    // Slope +1/2 after the minimum: sigma = K sqrt(tau / 3), read at tau = 3 s.
    if (i >= i_min && std::abs(s - 0.5) < 0.15 && curve[i].terms >= 10) {
      sum_rw += std::log(curve[i].deviation * std::sqrt(3.0 / curve[i].tau_s));
      ++n_rw;
    }
  }
  if (n_white > 0) f.white_density = std::exp(sum_white / n_white);
  if (n_rw > 0) f.random_walk = std::exp(sum_rw / n_rw);
  // A minimum at the end of the curve is not a flat floor: the instability is not reached.
  if (i_min + 1 < curve.size()) {
    f.bias_instability = curve[i_min].deviation / 0.664;
    f.bias_instability_tau_s = curve[i_min].tau_s;
  }
  return f;
}

double sample_period_s(const Recording& rec) {
  if (rec.sample_rate_hz > 0) return 1.0 / rec.sample_rate_hz;
  std::vector<double> dt;
  for (std::size_t k = 1; k < rec.samples.size(); ++k)
    if (rec.samples[k].pos == rec.samples[k - 1].pos)
      dt.push_back(rec.samples[k].t_s - rec.samples[k - 1].t_s);
  const std::optional<double> step = median_step_s(std::move(dt));
  if (!step)
    throw std::runtime_error(rec.source +
                             ": cannot tell the sample rate (no sample_rate_hz header)");
  return *step;
}

std::optional<double> median_step_s(std::vector<double> steps_s) {
  if (steps_s.empty()) return std::nullopt;
  const auto mid = steps_s.begin() + static_cast<std::ptrdiff_t>(steps_s.size() / 2);
  std::nth_element(steps_s.begin(), mid, steps_s.end());
  return *mid;
}

DwellAllan dwell_allan(const Recording& rec) {
  if (rec.samples.size() < kMinAllanSamples)
    throw std::runtime_error(rec.source + ": too few samples for an Allan deviation");
  const double period_s = sample_period_s(rec);
  std::array<AllanAccumulator, 3> pooled{AllanAccumulator(period_s), AllanAccumulator(period_s),
                                         AllanAccumulator(period_s)};
  const double to_ug = 1.0 / rec.g_local_mps2 / kUg;
  std::size_t first = 0;
  for (std::size_t k = 1; k <= rec.samples.size(); ++k) {
    if (k < rec.samples.size() && rec.samples[k].pos == rec.samples[first].pos) continue;
    for (int a = 0; a < 3; ++a) {
      std::vector<double> segment;
      segment.reserve(k - first + 1);
      for (std::size_t i = first; i < k; ++i) segment.push_back(rec.samples[i].f_mps2[a] * to_ug);
      pooled[a].add_segment(segment);
    }
    first = k;
  }
  return finish_dwell_allan(period_s, pooled);
}

DwellAllan finish_dwell_allan(double sample_period_s,
                              const std::array<AllanAccumulator, 3>& pooled) {
  DwellAllan out;
  out.sample_period_s = sample_period_s;
  out.segments = pooled[0].segments();
  for (std::size_t a = 0; a < 3; ++a) {
    out.curves[a] = pooled[a].curve();
    out.figures[a] = noise_figures(out.curves[a]);
  }
  return out;
}

std::optional<AllanFinding> allan_finding(const Recording& rec) {
  try {
    const DwellAllan a = dwell_allan(rec);
    return AllanFinding{a.sample_period_s, a.segments, a.figures};
  } catch (const std::exception&) {
    // Too few samples, no rate or repeated time stamps (a zero period): the fit's noise says
    // nothing of Allan rather than refusing the calibration.
    return std::nullopt;
  }
}

}  // namespace standcal
