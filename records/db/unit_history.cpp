#include "records/db/unit_history.hpp"

#include "calib/parameters.hpp"
#include "calib/utc_time.hpp"

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

// Each calibration's start in days (0 when it has none that parses), read once for all
// nine parameters.
std::vector<double> start_days(const std::vector<CalibrationRecord>& calibrations) {
  std::vector<double> days;
  for (const CalibrationRecord& r : calibrations) {
    const auto start_s = parse_utc_s(r.started_utc);
    days.push_back(start_s ? static_cast<double>(*start_s) / 86400.0 : 0.0);
  }
  return days;
}

// The one ageing rule over the parameter's points (one per calibration, in order).
std::vector<ParameterChange> changes_of(const std::vector<ParameterPoint>& points,
                                        const std::vector<double>& days, double k) {
  std::vector<ParameterObservation> dated;
  for (std::size_t i = 0; i < points.size(); ++i)
    dated.push_back({points[i].run_id, days[i], points[i].value, points[i].sigma});
  return parameter_changes(dated, k);
}

}  // namespace

UnitHistory unit_history(const std::string& unit_serial,
                         std::vector<CalibrationRecord> calibrations, double k) {
  UnitHistory h;
  h.unit_serial = unit_serial;
  h.k = k;
  h.calibrations = std::move(calibrations);
  const std::vector<double> days = start_days(h.calibrations);
  for (std::size_t j = 0; j < kUnitParameterNames.size(); ++j) {
    ParameterHistory ph;
    ph.name = std::string(kUnitParameterNames[j]);
    ph.unit = std::string(kUnitParameterUnits[j]);
    for (const CalibrationRecord& r : h.calibrations) ph.points.push_back(point_of(r, ph.name));
    ph.changes = changes_of(ph.points, days, k);
    for (const ParameterChange& c : ph.changes) h.ageing_flags += c.ageing ? 1 : 0;
    h.parameters.push_back(std::move(ph));
  }
  return h;
}

}  // namespace standcal::records
