#pragma once
// Who, what, where and when of one calibration: the facts that a run's record (run.json),
// its result (result.json's "traceability"), the records database and a certificate all
// carry about it. One struct, which those records extend, and one JSON form.
#include <nlohmann/json.hpp>
#include <string>

namespace standcal {

struct Traceability {
  std::string run_id;  // standcald's run id ("import-…" for an imported recording)
  std::string unit_serial;
  std::string unit_type;  // "" when not known (acceptance limits are per unit type)
  std::string stand_id;
  std::string program_name;
  std::string operator_name;
  std::string started_utc;  // calib/utc_time.hpp's form
  std::string ended_utc;
  std::string software_version;  // of the software that recorded the run
  std::string config_hash;       // of the daemon configuration that ran it
  std::string g_source;          // where the local gravity value came from
  double g_local_mps2 = 0;
};

// result.json's "traceability" object: run_id, unit_serial, unit_type, stand_id, program,
// operator, started_utc, ended_utc, software_version, config_hash, g_source, g_local_mps2.
nlohmann::json traceability_to_json(const Traceability& t);
// The same object read back; a missing key is an empty field (g: 0).
Traceability traceability_from_json(const nlohmann::json& j);

}  // namespace standcal
