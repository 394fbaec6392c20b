#include "calib/ageing.hpp"

#include <cmath>

namespace standcal {

std::vector<ParameterChange> parameter_changes(std::span<const ParameterObservation> oldest_first,
                                               double k) {
  std::vector<ParameterChange> out;
  const ParameterObservation* previous = nullptr;
  for (const ParameterObservation& now : oldest_first) {
    if (!now.value || !now.sigma) continue;
    if (previous != nullptr) {
      ParameterChange c;
      c.from_run_id = previous->run_id;
      c.to_run_id = now.run_id;
      c.delta = *now.value - *previous->value;
      c.combined_sigma = std::hypot(*now.sigma, *previous->sigma);
      c.days = now.days - previous->days;
      c.ageing = std::abs(c.delta) > k * c.combined_sigma;
      out.push_back(std::move(c));
    }
    previous = &now;
  }
  return out;
}

}  // namespace standcal
