#include "calib/averaging.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "calib/order_statistics.hpp"
#include "calib/text.hpp"
#include "calib/units.hpp"

namespace standcal {

namespace {

// Robust centre and scale of one axis of a block (values in g).
// `work` is working memory.
std::pair<double, double> robust_centre_scale(const std::vector<double>& values,
                                              std::vector<double>& work) {
  work.assign(values.begin(), values.end());
  const double median = median_in_place(work);
  for (double& v : work) v = std::abs(v - median);
  const double mad = median_in_place(work);
  return {median, std::max(1.4826 * mad, kRobustScaleFloor_g)};
}

std::runtime_error too_few_samples(const Recording& header, const DwellSamples& dwell,
                                   std::size_t usable) {
  return std::runtime_error(
      header.source + ": position " + std::to_string(dwell.head.pos) + " has " +
      std::to_string(usable) + " usable sample(s)" +
      (dwell.warmup_samples > 0 ? " after its warm-up of " + round_trip_text(header.warmup_s) + " s"
                                : "") +
      "; at least 2 are needed");
}

}  // namespace

Vec3 PositionAverage::up() const {
  return up_vector(alpha1_cmd_deg * kDegToRad, alpha2_cmd_deg * kDegToRad, mount);
}

std::vector<int> approach_directions(const std::vector<std::pair<double, double>>& alpha_cmd_deg) {
  std::vector<int> directions;
  double prev1 = 0, prev2 = 0;
  for (const auto& [a1, a2] : alpha_cmd_deg) {
    const double d1 = a1 - prev1, d2 = a2 - prev2;
    const double d = std::abs(d1) >= std::abs(d2) ? d1 : d2;
    directions.push_back(d < 0 ? -1 : +1);
    prev1 = a1;
    prev2 = a2;
  }
  return directions;
}

void DwellSamples::clear() {
  for (auto& axis : f_mps2) axis.clear();
  temp_c.clear();
  warmup_samples = 0;
}

void DwellSamples::add(const RecordingSample& s) {
  if (warm_up_row(s))
    ++warmup_samples;
  else if (size() == warmup_samples)
    measured_from_s = s.t_s;
  if (size() == 0) head = s;
  t_end_s = s.t_s;
  for (std::size_t a = 0; a < 3; ++a) f_mps2[a].push_back(s.f_mps2[static_cast<int>(a)]);
  if (with_temperature) temp_c.push_back(s.temp_c);
}

void DwellSamples::reserve(std::size_t rows) {
  for (auto& axis : f_mps2) axis.reserve(rows);
  if (with_temperature) temp_c.reserve(rows);
}

PositionAverage average_dwell(const DwellSamples& dwell, const Recording& header) {
  const std::size_t count = dwell.size();
  const std::size_t first = dwell.warmup_samples;  // the rows before it are the warm-up
  if (count - first < 2) throw too_few_samples(header, dwell, count - first);
  const double inv_g = 1.0 / header.g_local_mps2;
  std::vector<double> axis(count - first);
  std::vector<double> work;
  std::vector<char> keep(count, 1);
  for (std::size_t a = 0; a < 3; ++a) {
    for (std::size_t i = first; i < count; ++i) axis[i - first] = dwell.f_mps2[a][i] * inv_g;
    const auto [centre, scale] = robust_centre_scale(axis, work);
    for (std::size_t i = first; i < count; ++i)
      if (std::abs(axis[i - first] - centre) > kOutlierThreshold * scale) keep[i] = 0;
  }
  const RecordingSample& head = dwell.head;
  PositionAverage avg;
  avg.pos = head.pos;
  avg.alpha1_cmd_deg = head.alpha1_cmd_deg;
  avg.alpha2_cmd_deg = head.alpha2_cmd_deg;
  avg.mount = head.mount ? *head.mount : header.default_mount.value_or(Mount::x);
  avg.t_start_s = first > 0 ? dwell.measured_from_s : head.t_s;
  avg.t_end_s = dwell.t_end_s;
  const double settle_s = std::isnan(header.settle_s) ? 0.0 : header.settle_s;
  avg.t_arrive_s = std::isnan(head.t_arrive_s) ? head.t_s - settle_s : head.t_arrive_s;
  avg.approach = head.approach;

  Vec3 sum = Vec3::Zero(), sum_sq = Vec3::Zero();
  double temp_sum = 0;
  std::size_t temp_count = 0, n = 0;
  const bool temperatures = dwell.temp_c.size() == count;  // not kept: no mean
  for (std::size_t i = first; i < count; ++i) {
    if (!keep[i]) continue;
    for (std::size_t a = 0; a < 3; ++a) sum[static_cast<int>(a)] += dwell.f_mps2[a][i] * inv_g;
    ++n;
    if (temperatures && !std::isnan(dwell.temp_c[i])) {
      temp_sum += dwell.temp_c[i];
      ++temp_count;
    }
  }
  avg.samples = n;
  avg.outliers_rejected = count - first - n;
  if (n < 2) throw too_few_samples(header, dwell, n);
  avg.mean_g = sum / static_cast<double>(n);
  for (std::size_t i = first; i < count; ++i) {
    if (!keep[i]) continue;
    for (std::size_t a = 0; a < 3; ++a) {
      const double d = dwell.f_mps2[a][i] * inv_g - avg.mean_g[static_cast<int>(a)];
      sum_sq[static_cast<int>(a)] += d * d;
    }
  }
  avg.sigma_g = (sum_sq / static_cast<double>(n - 1)).cwiseSqrt();
  avg.standard_error_g = avg.sigma_g / std::sqrt(static_cast<double>(n));
  avg.temp_mean_c = temp_count ? temp_sum / static_cast<double>(temp_count) : std::nan("");
  return avg;
}

void derive_missing_approaches(std::vector<PositionAverage>& averages) {
  std::vector<std::pair<double, double>> commanded;
  for (const PositionAverage& a : averages)
    commanded.emplace_back(a.alpha1_cmd_deg, a.alpha2_cmd_deg);
  const std::vector<int> derived = approach_directions(commanded);
  for (std::size_t i = 0; i < averages.size(); ++i)
    if (averages[i].approach == 0) averages[i].approach = derived[i];
}

std::vector<PositionAverage> average_positions(const Recording& rec) {
  return average_recording(rec).averages;
}

AveragedRecording average_recording(const Recording& rec) {
  if (rec.samples.empty()) throw std::runtime_error(rec.source + ": the recording has no samples");
  std::vector<PositionAverage> out;
  DwellSamples dwell;
  dwell.warmup_s = rec.warmup_s;
  for (std::size_t i = 0; i < rec.samples.size(); ++i) {
    if (dwell.size() > 0 && rec.samples[i].pos != dwell.head.pos) {
      out.push_back(average_dwell(dwell, rec));
      dwell.clear();
    }
    dwell.add(rec.samples[i]);
  }
  out.push_back(average_dwell(dwell, rec));
  derive_missing_approaches(out);
  std::string why_no_allan;
  AveragedRecording averaged{std::move(out), allan_finding(rec, &why_no_allan), ""};
  averaged.allan_warning = allan_unavailable_warning(rec.samples.size(), why_no_allan);
  if (averaged.allan && !averaged.allan->gaps_warning.empty())
    averaged.allan_warning = rec.source + ": " + averaged.allan->gaps_warning;
  if (averaged.allan && averaged.allan->sample_correlation)
    widen_for_sample_correlation(averaged.averages, *averaged.allan->sample_correlation);
  return averaged;
}

void widen_for_sample_correlation(std::vector<PositionAverage>& averages,
                                  SampleCorrelation& correlation) {
  Vec3 scatter = Vec3::Zero();  // sum of (n - 1) sigma^2, g^2
  double dof = 0;
  for (const PositionAverage& a : averages) {
    if (a.samples < 2) continue;
    const double n1 = static_cast<double>(a.samples - 1);
    scatter += n1 * a.sigma_g.cwiseAbs2();
    dof += n1;
  }
  if (!(dof > 0)) return;
  correlation.factor = widening_factor(correlation, (scatter / dof).cwiseSqrt() / kUg);
  for (PositionAverage& a : averages)
    a.standard_error_g = a.standard_error_g.cwiseProduct(correlation.factor);
}

double correlation_widening(const PositionAverage& a, int axis) {
  const double white = a.sigma_g[axis] / std::sqrt(static_cast<double>(a.samples));
  if (!(white > 0) || a.samples < 2) return 1;
  const double widening = a.standard_error_g[axis] / white;
  return widening > 1 + 1e-9 ? widening : 1;  // sigma / sqrt(n) as computed: exactly 1
}

std::optional<double> mean_dwell_temperature_c(const std::vector<PositionAverage>& averages) {
  double sum = 0;
  int n = 0;
  for (const PositionAverage& a : averages) {
    if (std::isnan(a.temp_mean_c)) continue;
    sum += a.temp_mean_c;
    ++n;
  }
  if (n == 0) return std::nullopt;
  return sum / n;
}

}  // namespace standcal
