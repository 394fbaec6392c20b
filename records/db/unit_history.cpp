#include "records/db/unit_history.hpp"

#include <cmath>

#include "calib/parameters.hpp"

namespace standcal::records {

namespace {

using nlohmann::json;

std::optional<double> number_at(const json& p, const char* key) {
  if (!p.is_object() || !p.contains(key) || !p[key].is_number()) return std::nullopt;
  return p[key].get<double>();
}

ParameterPoint point_of(const CalibrationRecord& r, const std::string& name) {
  ParameterPoint pt{r.run_id, r.started_utc, std::nullopt, std::nullopt};
  if (r.result.is_object() && r.result.contains("parameters") &&
      r.result["parameters"].contains(name)) {
    const json& p = r.result["parameters"][name];
    pt.value = number_at(p, "value");
    pt.sigma = number_at(p, "sigma");
  }
  return pt;
}

// Consecutive calibrations where the parameter had a value and a σ.
std::vector<ParameterChange> changes_of(const std::vector<ParameterPoint>& points, double k) {
  std::vector<ParameterChange> out;
  const ParameterPoint* previous = nullptr;
  for (const ParameterPoint& p : points) {
    if (!p.value || !p.sigma) continue;
    if (previous != nullptr) {
      ParameterChange c;
      c.from_run_id = previous->run_id;
      c.to_run_id = p.run_id;
      c.delta = *p.value - *previous->value;
      c.combined_sigma = std::hypot(*p.sigma, *previous->sigma);
      c.ageing = std::abs(c.delta) > k * c.combined_sigma;
      out.push_back(c);
    }
    previous = &p;
  }
  return out;
}

}  // namespace

UnitHistory unit_history(const std::string& unit_serial,
                         std::vector<CalibrationRecord> calibrations, double k) {
  UnitHistory h;
  h.unit_serial = unit_serial;
  h.k = k;
  h.calibrations = std::move(calibrations);
  for (std::size_t j = 0; j < kUnitParameterNames.size(); ++j) {
    ParameterHistory ph;
    ph.name = std::string(kUnitParameterNames[j]);
    ph.unit = std::string(kUnitParameterUnits[j]);
    for (const CalibrationRecord& r : h.calibrations) ph.points.push_back(point_of(r, ph.name));
    ph.changes = changes_of(ph.points, k);
    for (const ParameterChange& c : ph.changes) h.ageing_flags += c.ageing ? 1 : 0;
    h.parameters.push_back(std::move(ph));
  }
  return h;
}

}  // namespace standcal::records
