#pragma once
// A unit's calibration history: each of the nine parameters over time with its expanded
// uncertainty, and the changes between successive calibrations larger than their
// combined uncertainty explains (ageing, damage, or a bad calibration). Plain structs so
// any source (the records database, a folder of result.json files) can feed it.
#include <array>
#include <optional>
#include <string>
#include <vector>

#include "calib/ageing.hpp"
#include "calib/parameters.hpp"

namespace standcal::report {

// One parameter of one calibration, in its report unit (µg, ppm, arcsec).
struct HistoryValue {
  std::optional<double> value;  // empty: not measured by that calibration's programme
  std::optional<double> sigma;  // 1 sigma
};

struct HistoryCalibration {
  std::string run_id;
  std::string date_utc;  // ISO 8601 UTC: "2026-11-21T22:36:38Z" or "20261121T223638Z"
  std::string verdict;   // conformity verdict if known ("pass", "fail", ...), may be empty
  std::array<HistoryValue, kUnitParameterCount> parameters;  // calib/parameters.hpp order
};

struct UnitHistory {
  std::string unit_serial;
  std::string unit_type;                         // may be empty
  std::vector<HistoryCalibration> calibrations;  // any order; sorted by date when drawn
  double coverage_factor = 2.0;                  // error bars are ±U = ±k·sigma
  // The source's own ageing verdicts, per parameter (calib/parameters.hpp order), when it
  // has them (the records database's history does): the page states those rather than
  // judging the same calibrations a second time. Empty: find_drifts applies the rule.
  std::optional<std::array<std::vector<ParameterChange>, kUnitParameterCount>> changes;
};

// A change between two successive calibrations bigger than k times its combined sigma.
struct HistoryDrift {
  int parameter = 0;
  std::string from_run_id, to_run_id;
  double change = 0;        // report units, later minus earlier
  double change_sigma = 0;  // sqrt(sigma1^2 + sigma2^2)
  double days = 0;          // time between the two calibrations
  std::string text;         // one sentence
};

// Days since 1970-01-01 of an ISO 8601 UTC stamp; throws std::runtime_error naming it.
double utc_days(const std::string& iso_utc);

// The changes between successive calibrations (by date) that the one ageing rule
// (calib/ageing.hpp, k = coverage_factor) flags, per parameter, each with its sentence;
// the source's own verdicts when `changes` holds them.
std::vector<HistoryDrift> find_drifts(const UnitHistory& history);

// A self-contained HTML page: a table of every calibration, the flagged drifts, and one
// inline SVG plot per parameter (value ± U over days since the first calibration).
// Throws std::runtime_error when a date cannot be read.
std::string render_history_html(const UnitHistory& history);

}  // namespace standcal::report
