#pragma once
// The ageing rule of a unit's calibration history, in one place: between successive
// calibrations that both observed a parameter (value and σ), the change is flagged when
// |Δ| > k · sqrt(σ₁² + σ₂²). With k = 2 an unchanged unit is flagged by chance about 5 %
// of the time per parameter and pair. The records database's history (`standcal history`)
// and the history page (report/history) both call it.
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace standcal {

// One parameter of one calibration, in its report unit (µg, ppm, arcsec).
struct ParameterObservation {
  std::string run_id;
  double days = 0;              // when, in days on any fixed scale (only differences are used)
  std::optional<double> value;  // empty: not observable in that calibration's programme
  std::optional<double> sigma;  // 1 σ
};

// Between two successive calibrations where the parameter was observed.
struct ParameterChange {
  std::string from_run_id;
  std::string to_run_id;
  double delta = 0;           // later − earlier, report unit
  double combined_sigma = 0;  // sqrt(σ_earlier² + σ_later²)
  double days = 0;            // time between the two calibrations
  bool ageing = false;        // |delta| > k · combined_sigma
};

// Every change between successive observed calibrations of `oldest_first` (a calibration
// without a value or a σ for the parameter is skipped, and the next one is compared with
// the one before it), each flagged by the rule above.
std::vector<ParameterChange> parameter_changes(std::span<const ParameterObservation> oldest_first,
                                               double k);

}  // namespace standcal
