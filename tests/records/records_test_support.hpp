#pragma once
// Shared by the records tests: temporary directories, the one PostgreSQL server of this
// test process, and simulated calibrations fitted the way the daemon fits them.
#include <gtest/gtest.h>

#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "calib/averaging.hpp"
#include "calib/invariant_estimator.hpp"
#include "calib/programs.hpp"
#include "calib/report.hpp"
#include "calib/simulator.hpp"
#include "records/db/records_db.hpp"
#include "tests/records/postgres_server.hpp"
#include "tests/support/temp_dir.hpp"

namespace standcal::test {

// Started on first use, stopped when the test process exits.
inline PostgresServer& postgres() {
  static const std::unique_ptr<PostgresServer> server = std::make_unique<PostgresServer>();
  return *server;
}

#define STANDCAL_REQUIRE_POSTGRES()                               \
  do {                                                            \
    if (!::standcal::test::postgres().skip_reason().empty())      \
      GTEST_SKIP() << "PostgreSQL test server could not start: "  \
                   << ::standcal::test::postgres().skip_reason(); \
  } while (0)

// A short paper9 run of `truth` (10 s dwell: seconds to simulate, µg-level σ).
inline Recording simulate_calibration(const TruthModel& truth, const std::string& serial,
                                      std::uint64_t seed) {
  SimulationRequest req;
  req.program = paper9();
  req.truth = truth;
  req.timing.dwell_s = 10;
  req.timing.settle_s = 2;
  req.seed = seed;
  req.unit_serial = serial;
  return simulate_run(req);
}

// What standcald stores as result.json at the end of a run (sequencer's finish_with_fit).
inline nlohmann::json daemon_result(const Recording& rec, const std::string& run_id,
                                    const std::string& started_utc,
                                    const std::string& recording_path) {
  nlohmann::json result = fit_to_json(fit_invariant_joint(average_positions(rec)));
  result["recording_path"] = recording_path;
  result["traceability"] = {{"run_id", run_id},
                            {"unit_serial", rec.unit_serial},
                            {"stand_id", "bench-2"},
                            {"program", rec.program},
                            {"g_local_mps2", rec.g_local_mps2},
                            {"g_source", "survey 2024, 9.81625 ± 0.00002"},
                            {"software_version", "0.1.0"},
                            {"config_hash", "c0ffee"},
                            {"operator", "A. Lovelace"},
                            {"started_utc", started_utc},
                            {"ended_utc", started_utc}};
  result["recording_warnings"] = rec.warnings;
  return result;
}

}  // namespace standcal::test
