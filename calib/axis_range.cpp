#include "calib/axis_range.hpp"

#include <cmath>

namespace standcal {

double wrap_deg(double angle_deg) {
  const double r = std::remainder(angle_deg, 360.0);  // [-180, 180]
  return r >= 180.0 ? r - 360.0 : r;
}

std::optional<double> equivalent_angle_deg(const AxisRange& range, double angle_deg,
                                           double reference_deg) {
  if (!std::isfinite(angle_deg)) return std::nullopt;
  const double wrapped_deg = wrap_deg(angle_deg);  // exact, so every candidate below is too
  if (range.continuous) return wrapped_deg;
  // Tolerance so that a range edge given as 180 still takes a command of -180.
  constexpr double kEdge_deg = 1e-9;
  const double lowest =
      wrapped_deg + 360.0 * std::ceil((range.min_deg - kEdge_deg - wrapped_deg) / 360.0);
  std::optional<double> best;
  for (double candidate = lowest; candidate <= range.max_deg + kEdge_deg; candidate += 360.0)
    if (!best || std::abs(candidate - reference_deg) < std::abs(*best - reference_deg))
      best = candidate;
  return best;
}

}  // namespace standcal
