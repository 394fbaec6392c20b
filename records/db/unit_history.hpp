#pragma once
// A unit's parameters over its calibrations, and where they moved more than the
// calibrations' own uncertainty explains (ageing). Used by `standcal history` and by
// the history plots. Library target: standcal_records_db.
#include <optional>
#include <string>
#include <vector>

#include "calib/ageing.hpp"
#include "records/db/records_db.hpp"

namespace standcal::records {

// One parameter in one calibration, in its report unit (µg, ppm, arcsec).
struct ParameterPoint {
  std::string run_id;
  std::string started_utc;
  std::optional<double> value;  // empty: not observable in that programme
  std::optional<double> sigma;
};

// The change between two successive calibrations and its ageing flag: calib/ageing.hpp.
using standcal::ParameterChange;

struct ParameterHistory {
  std::string name;                      // "bias_x", … (calib/parameters.hpp order)
  std::string unit;                      // "ug", "ppm", "arcsec"
  std::vector<ParameterPoint> points;    // oldest first
  std::vector<ParameterChange> changes;  // consecutive observed pairs
};

struct UnitHistory {
  std::string unit_serial;
  double k = 2;                                 // coverage factor used for the ageing flag
  std::vector<CalibrationRecord> calibrations;  // oldest first
  std::vector<ParameterHistory> parameters;     // the nine unit parameters
  int ageing_flags = 0;                         // changes flagged over all parameters
};

// `calibrations` in time order (RecordsDb::history gives them so); changes flagged by the
// one ageing rule (calib/ageing.hpp).
UnitHistory unit_history(const std::string& unit_serial,
                         std::vector<CalibrationRecord> calibrations, double k = 2);

}  // namespace standcal::records
