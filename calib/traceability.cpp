#include "calib/traceability.hpp"

namespace standcal {

nlohmann::json traceability_to_json(const Traceability& t) {
  return nlohmann::json{{"run_id", t.run_id},
                        {"unit_serial", t.unit_serial},
                        {"unit_type", t.unit_type},
                        {"stand_id", t.stand_id},
                        {"program", t.program_name},
                        {"operator", t.operator_name},
                        {"started_utc", t.started_utc},
                        {"ended_utc", t.ended_utc},
                        {"software_version", t.software_version},
                        {"config_hash", t.config_hash},
                        {"g_source", t.g_source},
                        {"g_local_mps2", t.g_local_mps2}};
}

Traceability traceability_from_json(const nlohmann::json& j) {
  Traceability t;
  if (!j.is_object()) return t;
  t.run_id = j.value("run_id", "");
  t.unit_serial = j.value("unit_serial", "");
  t.unit_type = j.value("unit_type", "");
  t.stand_id = j.value("stand_id", "");
  t.program_name = j.value("program", "");
  t.operator_name = j.value("operator", "");
  t.started_utc = j.value("started_utc", "");
  t.ended_utc = j.value("ended_utc", "");
  t.software_version = j.value("software_version", "");
  t.config_hash = j.value("config_hash", "");
  t.g_source = j.value("g_source", "");
  t.g_local_mps2 = j.value("g_local_mps2", 0.0);
  return t;
}

}  // namespace standcal
