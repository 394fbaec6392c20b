#pragma once
// The compensation an INS loads, f = M (raw - b), as one file format for every estimator
// (standcal-compensation/2, docs/calibration.md "Compensation"): the numbers with
// their units, standard uncertainties and covariance, the identity of the unit and of the
// calibration they belong to, and a checksum over the numbers so a loader can tell a
// damaged or hand-edited file from the one standcal wrote.
#include <Eigen/Dense>
#include <nlohmann/json_fwd.hpp>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "calib/averaging.hpp"
#include "calib/fit_result.hpp"
#include "calib/recording.hpp"
#include "calib/units.hpp"

namespace standcal {

struct NormFit;
struct RawInput;

inline constexpr const char* kCompensationFormat = "standcal-compensation/2";

// Which unit, which calibration: empty strings and no temperature when not known.
struct CompensationIdentity {
  std::string unit_serial;
  std::string unit_type;
  std::string run_id;
  std::string stand_id;
  std::string calibrated_utc;  // when the data were taken (the run's end, or the file's start)
  std::string source;          // the recording
  std::string g_source;
  // The unit's temperature during the calibration: the compensation holds there.
  std::optional<double> temperature_reference_c;
  std::string temperature_how;
};

// The order of `covariance`: b_x, b_y, b_z, then M row by row (M_11, M_12, ... M_33).
inline constexpr int kCompensationValues = 12;
using CompensationCovariance = Eigen::Matrix<double, kCompensationValues, kCompensationValues>;

struct Compensation {
  std::string estimator;              // the fit it came from: joint, full, norm, ...
  std::string input_units = "m/s^2";  // of raw and b: "m/s^2", "g" or "counts"
  Vec3 bias = Vec3::Zero();           // b, input units
  Mat3 matrix = Mat3::Identity();     // M: input units -> m/s^2
  CompensationCovariance covariance = CompensationCovariance::Zero();
  double g_local_mps2 = kStandardGravity_mps2;
  CompensationIdentity identity;
  std::vector<std::string> notes;
  // Filled when written (compensation_to_json) or read back.
  std::string written_utc;
  std::string standcal_version;
};

// From a stand fit (raw in m/s^2): parameters the programme cannot observe are taken as 0,
// with a note, and carry no variance.
Compensation make_compensation(const FitResult& fit, double g_local_mps2);
// From the attitude-free fit, in the input's units.
Compensation make_compensation(const NormFit& fit, const RawInput& input);

// The identity of a calibration run: these fields, and the dwells' mean temperature as the
// reference the compensation holds at. calibrated_utc: when the run's data were taken.
struct RunIdentity {
  std::string unit_serial, unit_type, run_id, stand_id, calibrated_utc, source, g_source;
};
CompensationIdentity compensation_identity(const RunIdentity& run,
                                           const std::vector<PositionAverage>& averages);
// What a recording's header says of the unit and the run (standcald writes unit_serial,
// unit_type, run_id, stand_id and started_utc).
CompensationIdentity compensation_identity(const Recording& rec,
                                           const std::vector<PositionAverage>& averages);

// CRC-32 (zlib's) over "raw_units=UNITS\n" and the 12 numbers b_x .. M_33, each printed
// with "%.17g" and a newline: eight lower-case hex digits. Printing with %.17g and reading
// back gives the same double, so a loader in any language recomputes it from what it
// parsed. It covers what a loader applies (the units raw must be in, b and M); the
// covariance and the identity are not covered.
std::string compensation_checksum(const Compensation& c);

// A file that is not a standcal-compensation/2 document, or whose numbers do not match its
// checksum: the message names the field.
class CompensationError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Sets written_utc (now) and standcal_version when they are empty: once, so that the JSON
// and the CSV written from one Compensation agree.
void stamp_written(Compensation& c);
// Stamps a copy when it is not stamped.
nlohmann::json compensation_to_json(Compensation c);
Compensation compensation_from_json(const nlohmann::json& doc);
// The CSV view: identity as `# key: value` lines, then b and M's rows with their sigmas.
std::string compensation_to_csv(const Compensation& c);
// Writes FILE.json and its CSV view FILE.csv, each atomically with `mode` (a PATH ending in
// .json names the same pair); returns FILE.
std::string write_compensation(Compensation c, const std::string& path, unsigned mode = 0644);

}  // namespace standcal
