#include "calib/allan.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "calib/golden_section.hpp"
#include "calib/text.hpp"
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

double gauss_markov_allan_variance(double tau_c_s, double T_s) {
  const double x = T_s / tau_c_s;
  if (x < 1e-4) return 2 * x / 3;  // the series' first term: the exact form cancels badly
  const double e = -std::expm1(-x);
  return (2 * (x - e) - e * e) / (x * x);
}

namespace {

// One octave between the points fitted: overlapping estimates at nearby averaging times
// share most of their clusters, and the chi-square should count nearly independent ones.
constexpr double kFitPointSpacing = 2;

ThinnedAllanCurve thinned(const std::vector<AllanPoint>& curve, double sample_period_s) {
  ThinnedAllanCurve c;
  for (const AllanPoint& p : curve) {
    // A zero deviation (a stuck or saturated axis) has no relative error to weigh it by.
    if (!(p.deviation > 0) || !std::isfinite(p.deviation)) continue;
    if (!c.points.empty() && p.tau_s < kFitPointSpacing * c.points.back().tau_s) continue;
    c.points.push_back(p);
    c.clusters.push_back(std::max(1.0, static_cast<double>(p.terms) * sample_period_s / p.tau_s));
  }
  return c;
}

// One point's share of the Gamma deviance: k ((y - m) / m - log(y / m)) for an Allan
// variance y from k independent clusters against the model's m.
double point_deviance(double observed, double model, double clusters) {
  const double z = (observed - model) / model;
  return clusters * (z - std::log1p(z));
}

struct AxisAtTau {
  double white_var = 0, wander_var = 0;  // N^2 (unit^2 s) and q^2 (unit^2)
  double deviance = 0;
};

// The best N^2 and q^2 (both >= 0) of one axis at one tau_c. An Allan variance estimated
// from k independent clusters is its true value times chi2_k / k, a Gamma variable of
// relative variance 2 / k: the maximum-likelihood fit is weighted least squares with each
// point's sigma its model variance times sqrt(2 / k), iterated (a Gamma GLM, identity
// link), and its deviance, sum k ((y - m) / m - log(y / m)), is what the profile over tau_c
// compares. (The Pearson chi-square in its place ran the fitted tau_c 6-17 % high.)
// tau_c_s 0: white noise alone (q = 0). With `wander_var` given, q^2 is held at it and N^2
// alone fitted (the profile over q: wander_size_ranges).
AxisAtTau fit_axis_at_tau(const ThinnedAllanCurve& c, double tau_c_s,
                          std::optional<double> wander_var = std::nullopt) {
  const std::size_t n = c.points.size();
  std::vector<double> observed(n), h(n), scale(n);
  for (std::size_t i = 0; i < n; ++i) {
    observed[i] = c.points[i].deviation * c.points[i].deviation;
    h[i] = tau_c_s > 0 ? gauss_markov_allan_variance(tau_c_s, c.points[i].tau_s) : 0.0;
    scale[i] = observed[i];
  }
  // A model variance of zero (one term fitted away) must not weigh a point infinitely.
  const double scale_floor = 1e-12 * *std::max_element(observed.begin(), observed.end());
  AxisAtTau r;
  for (int pass = 0; pass < 4; ++pass) {
    double s11 = 0, s12 = 0, s22 = 0, r1 = 0, r2 = 0;
    for (std::size_t i = 0; i < n; ++i) {
      const double w = c.clusters[i] / 2 / (scale[i] * scale[i]);
      const double white = 1 / c.points[i].tau_s;
      s11 += w * white * white, s12 += w * white * h[i], s22 += w * h[i] * h[i];
      r1 += w * white * observed[i], r2 += w * h[i] * observed[i];
    }
    const double det = s11 * s22 - s12 * s12;
    double a = det > 0 ? (s22 * r1 - s12 * r2) / det : r1 / s11;
    double b = det > 0 ? (s11 * r2 - s12 * r1) / det : 0;
    if (a < 0) a = 0, b = std::max(r2 / s22, 0.0);  // one term alone where both cannot be
    if (b < 0) b = 0, a = std::max(r1 / s11, 0.0);
    if (wander_var) b = *wander_var, a = std::max((r1 - s12 * b) / s11, 0.0);
    r = {a, b, 0};
    for (std::size_t i = 0; i < n; ++i) {
      const double model = a / c.points[i].tau_s + b * h[i];
      scale[i] = std::max(model, scale_floor);
      r.deviance += point_deviance(observed[i], scale[i], c.clusters[i]);
    }
  }
  return r;
}

struct ProfilePoint {
  double log_tau = 0;
  std::vector<AxisAtTau> axes;
  double deviance = 0;  // summed over the axes
};

// The point of the curves farthest from a fit (white noise alone where its log tau_c is
// -infinity), by its share of the deviance.
GaussMarkovAllanFit::Departure worst_departure(const std::vector<ThinnedAllanCurve>& curves,
                                               const ProfilePoint& fit) {
  GaussMarkovAllanFit::Departure worst;
  const double tau_c_s = std::exp(fit.log_tau);
  for (std::size_t a = 0; a < curves.size(); ++a) {
    const ThinnedAllanCurve& c = curves[a];
    for (std::size_t i = 0; i < c.points.size(); ++i) {
      const double T = c.points[i].tau_s;
      const double h = tau_c_s > 0 ? gauss_markov_allan_variance(tau_c_s, T) : 0.0;
      const double model = fit.axes[a].white_var / T + fit.axes[a].wander_var * h;
      if (!(model > 0)) continue;
      const double observed = c.points[i].deviation * c.points[i].deviation;
      const double deviance = point_deviance(observed, model, c.clusters[i]);
      if (deviance > worst.deviance) worst = {a, T, std::sqrt(observed / model), deviance};
    }
  }
  return worst;
}

// The deviance of the curves with one axis's wander held at q^2 = wander_var: the other axes
// and every white noise at their best, tau_c the best of the profile's (its grid and the
// refined best).
double deviance_at_size(const std::vector<ThinnedAllanCurve>& curves,
                        const std::vector<ProfilePoint>& profile, std::size_t axis,
                        double wander_var) {
  double least = std::numeric_limits<double>::infinity();
  for (const ProfilePoint& p : profile) {
    const double held = fit_axis_at_tau(curves[axis], std::exp(p.log_tau), wander_var).deviance;
    least = std::min(least, p.deviance - p.axes[axis].deviance + held);
  }
  return least;
}

// Each axis's q the curves allow: its profile deviance (white noise, the other axes and tau_c
// free) within `allowed`. The lower end 0 where no wander on that axis is allowed; the upper
// infinite where a wander too slow for the curves to show could be as large as it likes.
void wander_size_ranges(GaussMarkovAllanFit& fit, const std::vector<ThinnedAllanCurve>& curves,
                        const std::vector<ProfilePoint>& profile, double allowed) {
  const double q_scale = *std::max_element(fit.q.begin(), fit.q.end());
  constexpr double kOpenAbove = 1000;  // x the largest q: no bound from these curves
  constexpr int kBisections = 40;
  for (std::size_t a = 0; a < curves.size(); ++a) {
    const auto outside = [&](double q) {
      return deviance_at_size(curves, profile, a, q * q) > allowed;
    };
    double lo = 0, hi = fit.q[a];
    const bool needs_wander = outside(0);
    for (int i = 0; needs_wander && i < kBisections; ++i) {
      const double mid = 0.5 * (lo + hi);
      (outside(mid) ? lo : hi) = mid;
    }
    fit.q_min.push_back(needs_wander ? hi : 0.0);
    lo = fit.q[a], hi = std::max(2 * fit.q[a], 0.1 * q_scale);
    while (!outside(hi) && hi < kOpenAbove * q_scale) lo = hi, hi *= 2;
    if (!outside(hi)) {
      fit.q_max.push_back(std::numeric_limits<double>::infinity());
      continue;
    }
    for (int i = 0; i < kBisections; ++i) {
      const double mid = 0.5 * (lo + hi);
      (outside(mid) ? hi : lo) = mid;
    }
    fit.q_max.push_back(hi);
  }
}

ProfilePoint fit_at_tau(const std::vector<ThinnedAllanCurve>& curves, double log_tau) {
  ProfilePoint p{log_tau, {}, 0};
  for (const ThinnedAllanCurve& c : curves) {
    p.axes.push_back(fit_axis_at_tau(c, std::exp(log_tau)));
    p.deviance += p.axes.back().deviance;
  }
  return p;
}

}  // namespace

std::optional<GaussMarkovAllanFit> fit_gauss_markov_allan(
    const std::vector<std::vector<AllanPoint>>& axis_curves, double sample_period_s) {
  std::vector<ThinnedAllanCurve> curves;
  std::size_t points = 0;
  double T_first = std::numeric_limits<double>::infinity(), T_last = 0;
  for (const auto& curve : axis_curves) {
    curves.push_back(thinned(curve, sample_period_s));
    if (curves.back().points.size() < kGaussMarkovFitMinPoints) return std::nullopt;
    points += curves.back().points.size();
    T_first = std::min(T_first, curves.back().points.front().tau_s);
    T_last = std::max(T_last, curves.back().points.back().tau_s);
  }
  if (curves.empty()) return std::nullopt;
  // tau_c from the shortest averaging time to far beyond the curve's end, where the wander
  // is a random walk over every averaging time the curve has: a profile over log tau_c.
  const double lo = std::log(T_first), hi = std::log(30 * T_last);
  constexpr double kStepsPerDecade = 20;
  const int steps = static_cast<int>(std::ceil((hi - lo) / std::log(10.0) * kStepsPerDecade));
  std::vector<ProfilePoint> profile;
  for (int k = 0; k <= steps; ++k)
    profile.push_back(fit_at_tau(curves, lo + (hi - lo) * k / steps));
  std::size_t ib = 0;
  for (std::size_t k = 1; k < profile.size(); ++k)
    if (profile[k].deviance < profile[ib].deviance) ib = k;
  const auto refined = golden_section_max(
      [&](double log_tau) { return fit_at_tau(curves, log_tau); },
      profile[ib > 0 ? ib - 1 : 0].log_tau, profile[std::min(ib + 1, profile.size() - 1)].log_tau,
      20, [](const ProfilePoint& a, const ProfilePoint& b) { return a.deviance < b.deviance; });
  const ProfilePoint& best =
      refined.second.deviance < profile[ib].deviance ? refined.second : profile[ib];

  GaussMarkovAllanFit fit;
  for (const AxisAtTau& a : best.axes) {
    fit.white_density.push_back(std::sqrt(a.white_var));
    fit.q.push_back(std::sqrt(a.wander_var));
  }
  fit.tau_s = std::exp(best.log_tau);
  // N and q per axis and one tau.
  const double dof = static_cast<double>(points) - 2.0 * static_cast<double>(curves.size()) - 1;
  fit.deviance_per_dof = best.deviance / std::max(dof, 1.0);
  const double allowed =
      best.deviance + kGaussMarkovTauRangeDeviance * std::max(1.0, fit.deviance_per_dof);
  // The grid points within `allowed`, each end then out to the next grid point: the
  // crossing lies somewhere in that step (12 %), and the range must not be the narrower.
  std::size_t first = ib, last = ib;
  for (std::size_t k = 0; k < profile.size(); ++k)
    if (profile[k].deviance <= allowed) first = std::min(first, k), last = std::max(last, k);
  // Seen only where the wander beats white noise alone by the likelihood ratio of its
  // parameters (a q per axis and tau_c): the last octaves' few clusters scatter, and a
  // wander slow beyond the curve's end fits that scatter as a random walk. White noise is
  // then the model reported.
  ProfilePoint white{-std::numeric_limits<double>::infinity(), {}, 0};
  for (const ThinnedAllanCurve& c : curves) {
    white.axes.push_back(fit_axis_at_tau(c, 0));
    white.deviance += white.axes.back().deviance;
  }
  fit.wander_deviance = white.deviance - best.deviance;
  fit.wander_seen =
      std::any_of(fit.q.begin(), fit.q.end(), [](double q) { return q > 0; }) &&
      fit.wander_deviance > kGaussMarkovWanderDeviance * std::max(1.0, fit.deviance_per_dof);
  fit.tau_open_above = last + 1 >= profile.size();
  fit.tau_min_s = std::min(fit.tau_s, std::exp(profile[first > 0 ? first - 1 : 0].log_tau));
  fit.tau_max_s =
      std::max(fit.tau_s, std::exp(profile[std::min(last + 1, profile.size() - 1)].log_tau));
  // A correlation time the curves allow no longer than a second (or a few sample periods)
  // is the samples' own correlation (the unit's output filter or decimation), not a bias
  // wander: dwell means average it as white noise, of variance 2 q^2 tau_c per hertz beside
  // N^2. The whole range must lie below: a slow wander the curves also allow is no filter.
  const bool short_range = fit.wander_seen && fit.tau_max_s <= short_correlation_limit_s(T_first);
  // It widens every dwell mean's error and is reported as the unit's filter: a bar of
  // P = 1e-6 (white noise's chance excess at the first octaves met the wander's own bar in 2
  // of 1000 simulated runs; real filters beat it by hundreds).
  fit.short_correlation =
      short_range &&
      fit.wander_deviance > kShortCorrelationDeviance * std::max(1.0, fit.deviance_per_dof);
  if (short_range && !fit.short_correlation) fit.wander_seen = false;  // white noise, then
  if (fit.short_correlation) {
    fit.short_q = fit.q;
    for (std::size_t a = 0; a < fit.q.size(); ++a)
      fit.white_density[a] = std::sqrt(fit.white_density[a] * fit.white_density[a] +
                                       2 * fit.q[a] * fit.q[a] * fit.tau_s);
    fit.wander_seen = false;
  }
  fit.tau_bounded = fit.wander_seen && first > 0 && !fit.tau_open_above;
  // How well the model reported describes the curves: white noise alone where no wander (nor
  // short correlation) is seen, with N per axis as its only parameters.
  const bool white_reported = !fit.wander_seen && !fit.short_correlation;
  if (white_reported) {
    for (std::size_t a = 0; a < curves.size(); ++a)
      fit.white_density[a] = std::sqrt(white.axes[a].white_var);
    fit.deviance_per_dof =
        white.deviance / std::max(static_cast<double>(points - curves.size()), 1.0);
  }
  if (!fit.wander_seen) fit.q.assign(curves.size(), 0.0);  // white alone, or short correlation
  if (fit.wander_seen) {
    std::vector<ProfilePoint> candidates = profile;
    candidates.push_back(best);
    wander_size_ranges(
        fit, curves, candidates,
        best.deviance + kGaussMarkovSizeRangeDeviance * std::max(1.0, fit.deviance_per_dof));
  }
  fit.describes_curves = fit.deviance_per_dof <= kGaussMarkovFitScatterLimit;
  fit.worst_departure = worst_departure(curves, white_reported ? white : best);
  return fit;
}

double sample_period_s(const Recording& rec) {
  if (rec.sample_rate_hz > 0) return 1.0 / rec.sample_rate_hz;
  std::vector<double> dt;
  const double warm_up_end_s = warmup_end_s(rec);  // its step to the dwell is no period
  for (std::size_t k = 1; k < rec.samples.size(); ++k)
    if (one_segment(rec.samples[k - 1], rec.samples[k], warm_up_end_s))
      dt.push_back(rec.samples[k].t_s - rec.samples[k - 1].t_s);
  const std::optional<double> step = median_step_s(std::move(dt));
  if (!step)
    throw std::runtime_error(rec.source +
                             ": cannot tell the sample rate (no sample_rate_hz header)");
  if (const std::string why = unusable_step_text(*step); !why.empty())
    throw std::runtime_error(rec.source + ": " + why + " (no sample_rate_hz header)");
  return *step;
}

std::string unusable_step_text(double step_s) {
  if (!(step_s > 0)) return "the median time step is zero: repeated time stamps, no sample period";
  if (step_s > kMaxAbsTime_s)
    return "the median time step is " + number_texts_apart(step_s, kMaxAbsTime_s).value +
           " s, beyond 1e12 s: no sample period";
  if (!is_plausible_sample_rate(1 / step_s))
    return "the median time step is " + number_texts_apart(step_s, 1 / kMaxSampleRate_hz).value +
           " s, more than 1e6 samples a second: no sample period (are the times in another "
           "unit?)";
  return "";
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
  const double warm_up_end_s = warmup_end_s(rec);
  DwellGaps gaps;
  std::size_t first = 0;
  for (std::size_t k = 1; k <= rec.samples.size(); ++k) {
    // A warm-up is a segment of its own: the daemon's time between it and the dwell is no
    // sample period.
    if (k < rec.samples.size() && one_segment(rec.samples[k - 1], rec.samples[k], warm_up_end_s)) {
      gaps.add_step(rec.samples[k].t_s - rec.samples[k - 1].t_s, period_s);
      continue;
    }
    for (int a = 0; a < 3; ++a) {
      std::vector<double> segment;
      segment.reserve(k - first + 1);
      for (std::size_t i = first; i < k; ++i) segment.push_back(rec.samples[i].f_mps2[a] * to_ug);
      pooled[a].add_segment(segment);
    }
    first = k;
  }
  return finish_dwell_allan(period_s, pooled, gaps);
}

void DwellGaps::add_step(double step_s, double period_s) {
  sample_period_s = period_s;
  spanned_s += step_s;
  ++steps;
  if (step_s > 1.5 * period_s) ++count;
}

void DwellGaps::add(const DwellGaps& other) {
  count += other.count;
  steps += other.steps;
  spanned_s += other.spanned_s;
  if (other.steps > 0) sample_period_s = other.sample_period_s;
}

bool DwellGaps::too_much() const { return mismatch_share() > kMaxDwellGapShare; }

std::string DwellGaps::warning(std::string_view stretches) const {
  if (!too_much()) return "";
  const std::string held(stretches);
  char text[640];
  if (beyond_stamps_s() > 0)
    std::snprintf(text, sizeof text,
                  "the %s' %zu steps of the sample period %.4g s make %.3g s, %.3g s more than "
                  "their time stamps span (%.1f %% of it): the stamps and the sample rate "
                  "disagree (the stamps say a faster rate, or they bunch), gaps in the samples "
                  "would not show, and their Allan curves, which take the samples as evenly "
                  "spaced at that period, may show the wrong correlation times, so no bias "
                  "wander is read off them",
                  held.c_str(), steps, sample_period_s,
                  static_cast<double>(steps) * sample_period_s, beyond_stamps_s(),
                  100 * mismatch_share());
  else if (count == 0)  // no step stands out: the time is spread over every step
    std::snprintf(text, sizeof text,
                  "the %s' samples span %.3g s more than their %zu steps of the sample period "
                  "%.4g s (%.1f %% of their %.3g s): their time stamps and the sample rate "
                  "disagree, and their Allan curves, which take the samples as evenly spaced at "
                  "that period, may show the wrong correlation times, so no bias wander is read "
                  "off them",
                  held.c_str(), missing_s(), steps, sample_period_s, 100 * missing_share(),
                  spanned_s);
  else
    std::snprintf(text, sizeof text,
                  "the %s' samples miss %.3g s of their %.3g s in %zu gaps (%.1f %%): their "
                  "Allan curves take them as evenly spaced, which shortens the correlation "
                  "times they show, so no bias wander is read off them",
                  held.c_str(), missing_s(), spanned_s, count, 100 * missing_share());
  return text;
}

DwellAllan finish_dwell_allan(double sample_period_s, const std::array<AllanAccumulator, 3>& pooled,
                              const DwellGaps& gaps) {
  DwellAllan out;
  out.sample_period_s = sample_period_s;
  out.segments = pooled[0].segments();
  out.gaps = gaps;
  for (std::size_t a = 0; a < 3; ++a) {
    out.curves[a] = pooled[a].curve();
    out.figures[a] = noise_figures(out.curves[a]);
  }
  const std::vector<std::vector<AllanPoint>> curves{out.curves[0], out.curves[1], out.curves[2]};
  const std::optional<GaussMarkovAllanFit> fit = fit_gauss_markov_allan(curves, sample_period_s);
  if (fit) {
    out.sample_correlation = sample_correlation_of(*fit, sample_period_s);
    if (!gaps.too_much()) {
      const double end_s = curves_end_s(curves);
      out.wander = wander_to_give(*fit, end_s);
      out.wander_curves = wander_curves(*fit, curves, sample_period_s);
      out.wander_tau_floor_s = wander_tau_floor_s(*fit, end_s);
    }
  }
  return out;
}

double curves_end_s(const std::vector<std::vector<AllanPoint>>& curves) {
  double end_s = 0;
  for (const std::vector<AllanPoint>& c : curves)
    for (const AllanPoint& p : c) end_s = std::max(end_s, p.tau_s);
  return end_s;
}

std::optional<WanderToGive> wander_to_give(const GaussMarkovAllanFit& fit, double curves_end_s) {
  if (!fit.wander_seen || !fit.tau_bounded || !fit.describes_curves) return std::nullopt;
  const auto largest = std::max_element(fit.q.begin(), fit.q.end());
  const auto axis = static_cast<std::size_t>(largest - fit.q.begin());
  WanderToGive w;
  w.q = *largest;
  w.q_axes = fit.q;
  w.axes_at_bound.assign(fit.q.size(), false);
  for (std::size_t a = 0; a < fit.q.size() && a < fit.q_min.size(); ++a)
    if (fit.q_min[a] <= 0 && a != axis) {
      w.q_axes[a] = std::min(fit.q_max[a], w.q);
      w.axes_at_bound[a] = true;
    }
  if (axis < fit.q_min.size()) {
    w.q_min = fit.q_min[axis];
    w.q_max = fit.q_max[axis];
  }
  w.tau_min_s = fit.tau_min_s;
  w.tau_max_s = fit.tau_max_s;
  w.curves_end_s = curves_end_s;
  return w;
}

bool curves_show_turnover(double tau_max_s, double curves_end_s) {
  return curves_end_s >= kGaussMarkovAllanPeakPerTau * tau_max_s;
}

double wander_tau_floor_s(const GaussMarkovAllanFit& fit, double curves_end_s) {
  // A range reaching down to the shortest averaging time (not bounded below) puts no floor.
  const bool floor_short_of_turnover =
      fit.tau_bounded && !curves_show_turnover(fit.tau_max_s, curves_end_s);
  const bool not_pinned = fit.tau_open_above || floor_short_of_turnover;
  return fit.wander_seen && fit.describes_curves && not_pinned ? fit.tau_min_s : 0.0;
}

double WanderCurves::deviance(double q, double tau_c_s) const {
  double sum = 0;
  for (const ThinnedAllanCurve& c : axes)
    sum += fit_axis_at_tau(c, q > 0 ? tau_c_s : 0.0, q > 0 ? std::optional(q * q) : std::nullopt)
               .deviance;
  return deviance_scale * sum;
}

std::optional<WanderCurves> wander_curves(const GaussMarkovAllanFit& fit,
                                          const std::vector<std::vector<AllanPoint>>& curves,
                                          double sample_period_s) {
  if (!fit.describes_curves || fit.short_correlation || fit.wander_seen) return std::nullopt;
  WanderCurves out;
  for (const std::vector<AllanPoint>& curve : curves)
    out.axes.push_back(thinned(curve, sample_period_s));
  out.deviance_scale = kWanderCurvesDevianceScale / std::max(1.0, fit.deviance_per_dof);
  out.curves_end_s = curves_end_s(curves);
  return out;
}

namespace {

// What the curves' text holds, each refused naming `what` where it is not so.
double finite_number(const nlohmann::json& j, const std::string& what) {
  if (!j.is_number()) throw std::invalid_argument(what + " is not a number");
  const double v = j.get<double>();
  if (!std::isfinite(v)) throw std::invalid_argument(what + " is not finite");
  return v;
}
double positive_number(const nlohmann::json& j, const std::string& what) {
  const double v = finite_number(j, what);
  if (!(v > 0)) throw std::invalid_argument(what + " is " + j.dump() + ", not above 0");
  return v;
}
// A number within [min, max] (each bound one a static recording's curves can reach), refused
// naming `what` and the bounds otherwise.
double number_within(const nlohmann::json& j, const std::string& what, double min, double max) {
  const double v = positive_number(j, what);
  if (!(v >= min && v <= max))
    throw std::invalid_argument(what + " is " + j.dump() + ", outside " +
                                plain_round_trip_text(min) + " ... " + plain_round_trip_text(max));
  return v;
}

// What a static recording's curves (in ug) can hold: averaging times from the shortest sample
// period a recording has (kMaxSampleRate_hz) to the longest time (kMaxAbsTime_s); deviations of
// an accelerometer at rest from 1e-6 ug to 1 g; no more clusters than a recording's samples. Within
// them the deviance's sums are numbers; beyond, a curve reaching 7e105 ug beside its 0.2 ug made
// them overflow and the deviance NaN, which every fit of the run would have weighed (fuzz finding
// fuzz/regressions/wander_curves/deviation_7e105_clusters_5e11_deviance_nan, 2026-12-07).
constexpr double kMinCurveTau_s = 1 / kMaxSampleRate_hz, kMaxCurveTau_s = kMaxAbsTime_s;
constexpr double kMinCurveDeviation_ug = 1e-6, kMaxCurveDeviation_ug = 1e6;
constexpr double kMaxCurveClusters = 1e12;

const nlohmann::json& curves_array(const nlohmann::json& j, const char* key,
                                   const std::string& where) {
  if (!j.contains(key) || !j[key].is_array())
    throw std::invalid_argument(where + " has no array '" + key + "'");
  return j[key];
}

// One axis's points as wander_curves_text writes them: at least as many as a fit needs, their
// averaging times rising, each averaging time, deviation and count of clusters (at least one)
// within what a static recording's curves can hold (kMinCurveTau_s ...).
ThinnedAllanCurve parse_thinned_curve(const nlohmann::json& j, const std::string& where) {
  if (!j.is_object()) throw std::invalid_argument(where + " is not a JSON object");
  const nlohmann::json& taus = curves_array(j, "tau_s", where);
  const nlohmann::json& deviations = curves_array(j, "deviation", where);
  const nlohmann::json& clusters = curves_array(j, "clusters", where);
  if (taus.size() < kGaussMarkovFitMinPoints || deviations.size() != taus.size() ||
      clusters.size() != taus.size())
    throw std::invalid_argument(where +
                                ": 'tau_s', 'deviation' and 'clusters' need one value per "
                                "point, and at least " +
                                std::to_string(kGaussMarkovFitMinPoints) + " points");
  ThinnedAllanCurve c;
  for (std::size_t i = 0; i < taus.size(); ++i) {
    const std::string point = where + " point " + std::to_string(i + 1);
    AllanPoint p;
    p.tau_s = number_within(taus[i], point + " tau_s", kMinCurveTau_s, kMaxCurveTau_s);
    if (!c.points.empty() && !(p.tau_s > c.points.back().tau_s))
      throw std::invalid_argument(point + " tau_s does not rise from the point before");
    p.deviation = number_within(deviations[i], point + " deviation (ug)", kMinCurveDeviation_ug,
                                kMaxCurveDeviation_ug);
    c.points.push_back(p);
    c.clusters.push_back(number_within(clusters[i], point + " clusters", 1, kMaxCurveClusters));
  }
  return c;
}

}  // namespace

std::string wander_curves_text(const WanderCurves& curves) {
  nlohmann::json axes = nlohmann::json::array();
  for (const ThinnedAllanCurve& c : curves.axes) {
    nlohmann::json taus = nlohmann::json::array(), deviations = nlohmann::json::array();
    for (const AllanPoint& p : c.points) {
      taus.push_back(p.tau_s);
      deviations.push_back(p.deviation);
    }
    axes.push_back({{"tau_s", taus}, {"deviation", deviations}, {"clusters", c.clusters}});
  }
  return nlohmann::json{{"curves_end_s", curves.curves_end_s},
                        {"deviance_scale", curves.deviance_scale},
                        {"axes", axes}}
      .dump();
}

// The curves' end at or after every axis's last point, and the deviance's scale at most
// kWanderCurvesDevianceScale (wander_curves divides it by the curves' scatter, never more).
WanderCurves parse_wander_curves(std::string_view text) {
  const nlohmann::json j = nlohmann::json::parse(text, nullptr, false);
  if (j.is_discarded()) throw std::invalid_argument("not JSON");
  if (!j.is_object()) throw std::invalid_argument("not a JSON object");
  WanderCurves out;
  out.curves_end_s = number_within(j.value("curves_end_s", nlohmann::json()), "curves_end_s",
                                   kMinCurveTau_s, kMaxCurveTau_s);
  out.deviance_scale =
      positive_number(j.value("deviance_scale", nlohmann::json()), "deviance_scale");
  if (out.deviance_scale > kWanderCurvesDevianceScale)
    throw std::invalid_argument("deviance_scale is " + plain_round_trip_text(out.deviance_scale) +
                                ", above " + plain_round_trip_text(kWanderCurvesDevianceScale));
  const nlohmann::json& axes = curves_array(j, "axes", "the text");
  if (axes.size() != 3) throw std::invalid_argument("'axes' needs three curves, x, y and z");
  for (std::size_t a = 0; a < axes.size(); ++a) {
    const std::string axis = std::string("axis ") + "xyz"[a];
    out.axes.push_back(parse_thinned_curve(axes[a], axis));
    if (out.axes.back().points.back().tau_s > out.curves_end_s)
      throw std::invalid_argument("curves_end_s " + plain_round_trip_text(out.curves_end_s) +
                                  " s is before " + axis + "'s last point");
  }
  return out;
}

std::string wander_curves_text_error(std::string_view text) {
  try {
    parse_wander_curves(text);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

std::optional<SampleCorrelation> sample_correlation(
    const std::array<std::vector<AllanPoint>, 3>& curves, double sample_period_s) {
  const std::optional<GaussMarkovAllanFit> fit =
      fit_gauss_markov_allan({curves[0], curves[1], curves[2]}, sample_period_s);
  if (!fit) return std::nullopt;
  return sample_correlation_of(*fit, sample_period_s);
}

std::optional<SampleCorrelation> sample_correlation_of(const GaussMarkovAllanFit& fit,
                                                       double sample_period_s) {
  if (!fit.short_correlation) return std::nullopt;
  SampleCorrelation c;
  c.tau_s = fit.tau_s;
  c.tau_max_s = fit.tau_max_s;
  c.sample_period_s = sample_period_s;
  for (std::size_t a = 0; a < 3; ++a)
    c.dwell_white[static_cast<Eigen::Index>(a)] = fit.white_density[a];
  return c;
}

Vec3 widening_factor(const SampleCorrelation& correlation, const Vec3& sample_sigma_ug) {
  Vec3 factor = Vec3::Ones();
  for (Eigen::Index k = 0; k < 3; ++k) {
    const double assumed_ug_rthz = sample_sigma_ug[k] * std::sqrt(correlation.sample_period_s);
    if (assumed_ug_rthz > 0)
      factor[k] = std::max(1.0, correlation.dwell_white[k] / assumed_ug_rthz);
  }
  return factor;
}

std::optional<AllanFinding> allan_finding(const Recording& rec, std::string* why_none) {
  try {
    return allan_finding_of(dwell_allan(rec));
  } catch (const std::exception& e) {
    // Too few samples, no rate or repeated time stamps (a zero period): the fit's noise says
    // nothing of Allan rather than refusing the calibration.
    if (why_none) *why_none = e.what();
    return std::nullopt;
  }
}

AllanFinding allan_finding_of(const DwellAllan& a) {
  return {a.sample_period_s, a.segments,       a.figures,       a.sample_correlation,
          a.wander,          a.gaps.warning(), a.wander_curves, a.wander_tau_floor_s};
}

std::string no_sample_period_warning(const Recording& rec) {
  try {
    (void)sample_period_s(rec);
    return "";
  } catch (const std::exception& e) {
    return allan_unavailable_warning(rec.samples.size(), e.what());
  }
}

std::string allan_unavailable_warning(std::size_t samples, const std::string& why_none) {
  if (samples < kMinAllanSamples || why_none.empty()) return "";
  return why_none +
         "; the dwells have no Allan curve, so samples correlated within a dwell (a unit's "
         "output filter) are not allowed for in the means' errors";
}

}  // namespace standcal
