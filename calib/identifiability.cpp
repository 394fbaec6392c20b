#include "calib/identifiability.hpp"

#include <cmath>

#include "calib/parameters.hpp"

namespace standcal {

int distinct_orientations(const std::vector<PositionAverage>& positions) {
  std::vector<const PositionAverage*> seen;
  for (const PositionAverage& p : positions) {
    bool repeat = false;
    for (const PositionAverage* q : seen)
      repeat = repeat || (q->mount == p.mount && (q->up() - p.up()).norm() < 1e-9);
    if (!repeat) seen.push_back(&p);
  }
  return static_cast<int>(seen.size());
}

std::string positions_for_unknowns(const std::vector<PositionAverage>& positions, int unknowns) {
  const auto n = positions.size();
  const int distinct = distinct_orientations(positions);
  std::string s = std::to_string(n) + (n == 1 ? " position" : " positions");
  if (distinct != static_cast<int>(n))
    s += " (" + std::to_string(distinct) +
         (distinct == 1 ? " distinct orientation)" : " distinct orientations)");
  return s + " for " + std::to_string(unknowns) + " unknowns";
}

void require_positions(const std::vector<PositionAverage>& positions, const std::string& refusal) {
  if (positions.empty())
    throw CannotFit(refusal + ": " + positions_for_unknowns(positions, kUnitParameterCount));
  for (const PositionAverage& p : positions) {
    const bool finite = p.mean_g.allFinite() && p.standard_error_g.allFinite() &&
                        std::isfinite(p.alpha1_cmd_deg) && std::isfinite(p.alpha2_cmd_deg);
    if (!finite)
      throw CannotFit(refusal + ": position " + std::to_string(p.pos) +
                      " has a mean or standard error that is not a finite number");
  }
}

}  // namespace standcal
