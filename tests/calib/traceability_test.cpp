// The one traceability struct and its JSON form (calib/traceability.hpp).
#include "calib/traceability.hpp"

#include <gtest/gtest.h>

namespace standcal {
namespace {

TEST(Traceability, TheJsonFormRoundTripsEveryField) {
  Traceability t;
  t.run_id = "20261121T223638Z-AU-0042";
  t.unit_serial = "AU-0042";
  t.unit_type = "IMU-A";
  t.stand_id = "stand-B2";
  t.program_name = "paper9";
  t.operator_name = "R. Ortiz";
  t.started_utc = "2026-11-21T22:36:38Z";
  t.ended_utc = "2026-11-21T23:01:02Z";
  t.software_version = "0.1.0";
  t.config_hash = "sha256:abc";
  t.g_source = "survey 2026";
  t.g_local_mps2 = 9.80943;
  const nlohmann::json j = traceability_to_json(t);
  // The keys result.json has always had (docs/protocol.md, run.result).
  for (const char* key :
       {"run_id", "unit_serial", "unit_type", "stand_id", "program", "operator", "started_utc",
        "ended_utc", "software_version", "config_hash", "g_source", "g_local_mps2"})
    EXPECT_TRUE(j.contains(key)) << key;
  EXPECT_EQ(j.size(), 12u);
  const Traceability back = traceability_from_json(j);
  EXPECT_EQ(traceability_to_json(back), j);
  EXPECT_EQ(back.program_name, "paper9");
  EXPECT_EQ(back.operator_name, "R. Ortiz");
  EXPECT_DOUBLE_EQ(back.g_local_mps2, 9.80943);
}

TEST(Traceability, MissingKeysAreEmptyFields) {
  const Traceability t = traceability_from_json(nlohmann::json{{"unit_serial", "AU-7"}});
  EXPECT_EQ(t.unit_serial, "AU-7");
  EXPECT_EQ(t.run_id, "");
  EXPECT_EQ(t.g_local_mps2, 0);
  EXPECT_EQ(traceability_from_json(nlohmann::json(nullptr)).unit_serial, "");
}

}  // namespace
}  // namespace standcal
