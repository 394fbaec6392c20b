#include "calib/averaging.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace standcal {

namespace {

double median_of(std::vector<double>& values) {
  const auto mid = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), mid, values.end());
  double m = *mid;
  if (values.size() % 2 == 0) m = 0.5 * (m + *std::max_element(values.begin(), mid));
  return m;
}

// Robust centre and scale of one axis of a block (values in g).
std::pair<double, double> robust_centre_scale(std::vector<double> values) {
  const double median = median_of(values);
  for (double& v : values) v = std::abs(v - median);
  const double mad = median_of(values);
  return {median, std::max(1.4826 * mad, kRobustScaleFloor_g)};
}

PositionAverage average_block(const Recording& rec, std::size_t first, std::size_t count) {
  const double inv_g = 1.0 / rec.g_local_mps2;
  std::vector<double> axis(count);
  std::vector<char> keep(count, 1);
  for (int a = 0; a < 3; ++a) {
    for (std::size_t i = 0; i < count; ++i) axis[i] = rec.samples[first + i].f_mps2[a] * inv_g;
    const auto [centre, scale] = robust_centre_scale(axis);
    for (std::size_t i = 0; i < count; ++i)
      if (std::abs(axis[i] - centre) > kOutlierThreshold * scale) keep[i] = 0;
  }
  PositionAverage avg;
  const RecordingSample& head = rec.samples[first];
  avg.pos = head.pos;
  avg.alpha1_cmd_deg = head.alpha1_cmd_deg;
  avg.alpha2_cmd_deg = head.alpha2_cmd_deg;
  avg.mount = head.mount ? *head.mount : rec.default_mount.value_or(Mount::x);
  avg.t_start_s = head.t_s;
  avg.t_end_s = rec.samples[first + count - 1].t_s;
  const double settle_s = std::isnan(rec.settle_s) ? 0.0 : rec.settle_s;
  avg.t_arrive_s = std::isnan(head.t_arrive_s) ? head.t_s - settle_s : head.t_arrive_s;

  Vec3 sum = Vec3::Zero(), sum_sq = Vec3::Zero();
  double temp_sum = 0;
  std::size_t temp_count = 0, n = 0;
  for (std::size_t i = 0; i < count; ++i) {
    if (!keep[i]) continue;
    const RecordingSample& s = rec.samples[first + i];
    const Vec3 J = s.f_mps2 * inv_g;
    sum += J;
    ++n;
    if (!std::isnan(s.temp_c)) {
      temp_sum += s.temp_c;
      ++temp_count;
    }
  }
  avg.samples = n;
  avg.outliers_rejected = count - n;
  if (n < 2)
    throw std::runtime_error(rec.source + ": position " + std::to_string(head.pos) + " has " +
                             std::to_string(n) + " usable sample(s); at least 2 are needed");
  avg.mean_g = sum / static_cast<double>(n);
  for (std::size_t i = 0; i < count; ++i)
    if (keep[i]) sum_sq += (rec.samples[first + i].f_mps2 * inv_g - avg.mean_g).cwiseAbs2();
  avg.sigma_g = (sum_sq / static_cast<double>(n - 1)).cwiseSqrt();
  avg.standard_error_g = avg.sigma_g / std::sqrt(static_cast<double>(n));
  avg.temp_mean_c = temp_count ? temp_sum / static_cast<double>(temp_count) : std::nan("");
  return avg;
}

}  // namespace

Vec3 PositionAverage::up() const {
  return up_vector(alpha1_cmd_deg * kDegToRad, alpha2_cmd_deg * kDegToRad, mount);
}

std::vector<int> approach_directions(
    const std::vector<std::pair<double, double>>& alpha_cmd_deg) {
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

std::vector<PositionAverage> average_positions(const Recording& rec) {
  if (rec.samples.empty()) throw std::runtime_error(rec.source + ": the recording has no samples");
  std::vector<PositionAverage> out;
  std::vector<std::pair<double, double>> commanded;
  std::size_t first = 0;
  for (std::size_t i = 1; i <= rec.samples.size(); ++i) {
    if (i < rec.samples.size() && rec.samples[i].pos == rec.samples[first].pos) continue;
    out.push_back(average_block(rec, first, i - first));
    commanded.emplace_back(out.back().alpha1_cmd_deg, out.back().alpha2_cmd_deg);
    first = i;
  }
  const std::vector<int> derived = approach_directions(commanded);
  std::size_t block = 0;
  for (std::size_t i = 0; i < rec.samples.size(); ++i) {
    if (i > 0 && rec.samples[i].pos != rec.samples[i - 1].pos) ++block;
    if (i == 0 || rec.samples[i].pos != rec.samples[i - 1].pos)
      out[block].approach = rec.samples[i].approach != 0 ? rec.samples[i].approach : derived[block];
  }
  return out;
}

}  // namespace standcal
