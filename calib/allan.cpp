#include "calib/allan.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "calib/units.hpp"

namespace standcal {

std::vector<AllanPoint> overlapping_allan_deviation(const std::vector<std::vector<double>>& segments,
                                                    double sample_period_s, int points_per_decade) {
  if (!(sample_period_s > 0)) throw std::invalid_argument("Allan deviation: the sample period must be positive");
  std::size_t longest = 0;
  for (const auto& s : segments) longest = std::max(longest, s.size());
  // Phase (integrated signal) per segment: x_k = tau0 * sum of the first k samples.
  std::vector<std::vector<double>> phase;
  for (const auto& s : segments) {
    std::vector<double> x(s.size() + 1, 0.0);
    for (std::size_t k = 0; k < s.size(); ++k) x[k + 1] = x[k] + s[k] * sample_period_s;
    phase.push_back(std::move(x));
  }
  std::vector<long> cluster_sizes;
  const long max_m = static_cast<long>(longest / 3);
  for (double e = 0;; e += 1.0 / points_per_decade) {
    const long m = std::lround(std::pow(10.0, e));
    if (m > max_m) break;
    if (cluster_sizes.empty() || m != cluster_sizes.back()) cluster_sizes.push_back(m);
  }
  std::vector<AllanPoint> curve;
  for (long m : cluster_sizes) {
    double sum = 0;
    long terms = 0;
    for (const auto& x : phase) {
      const long n = static_cast<long>(x.size());
      for (long k = 0; k + 2 * m < n; ++k) {
        const double d = x[k + 2 * m] - 2 * x[k + m] + x[k];
        sum += d * d;
        ++terms;
      }
    }
    if (terms == 0) continue;
    const double tau = static_cast<double>(m) * sample_period_s;
    curve.push_back({tau, std::sqrt(sum / (2.0 * tau * tau * static_cast<double>(terms))), terms});
  }
  return curve;
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
    if (rec.samples[k].pos == rec.samples[k - 1].pos) dt.push_back(rec.samples[k].t_s - rec.samples[k - 1].t_s);
  if (dt.empty()) throw std::runtime_error(rec.source + ": cannot tell the sample rate (no sample_rate_hz header)");
  std::nth_element(dt.begin(), dt.begin() + static_cast<long>(dt.size() / 2), dt.end());
  return dt[dt.size() / 2];
}

DwellAllan dwell_allan(const Recording& rec) {
  if (rec.samples.size() < 30) throw std::runtime_error(rec.source + ": too few samples for an Allan deviation");
  DwellAllan out;
  out.sample_period_s = sample_period_s(rec);
  std::array<std::vector<std::vector<double>>, 3> segments;
  for (std::size_t k = 0; k < rec.samples.size(); ++k) {
    if (k == 0 || rec.samples[k].pos != rec.samples[k - 1].pos)
      for (auto& axis : segments) axis.emplace_back();
    for (int a = 0; a < 3; ++a) segments[a].back().push_back(rec.samples[k].f_mps2[a] / rec.g_local_mps2 / kUg);
  }
  out.segments = segments[0].size();
  for (int a = 0; a < 3; ++a) {
    out.curves[a] = overlapping_allan_deviation(segments[a], out.sample_period_s);
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
