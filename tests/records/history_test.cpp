// A unit's history: five simulated calibrations, the bias of x drifting after the third
// (ageing), everything else unchanged. The drift must be flagged, the stable parts not.
#include "records/db/unit_history.hpp"
#include "tests/records/records_test_support.hpp"

namespace standcal::records {
namespace {

constexpr double kDriftPerCalibration_ug = 40;

// Calibration i (0-based) of unit AU-0042: bias_x steps up by the drift from i = 3 on.
CalibrationRecord calibration(int i, const std::string& url) {
  TruthModel truth = default_truth();
  const int drift_steps = i >= 3 ? i - 2 : 0;
  truth.unit.bias_g.x() += drift_steps * kDriftPerCalibration_ug * kUg;
  const Recording rec =
      test::simulate_calibration(truth, "AU-0042", 100 + static_cast<std::uint64_t>(i));
  const std::string started = "2026-0" + std::to_string(i + 1) + "-15T09:00:00Z";
  const std::string run_id = "2026-0" + std::to_string(i + 1) + "-AU-0042";
  CalibrationRecord r =
      record_from_daemon_result(test::daemon_result(rec, run_id, started, "/rec/" + run_id));
  auto db = open_and_migrate(url);
  db->insert(r);
  return r;
}

TEST(UnitHistory, AnInjectedBiasDriftIsFlaggedAsAgeingAndTheStableParametersAreNot) {
  test::TempDir dir;
  const std::string url = dir.path() + "/records.sqlite";
  for (int i = 4; i >= 0; --i) calibration(i, url);  // stored out of order on purpose
  auto db = open_and_migrate(url);
  const UnitHistory h = unit_history("AU-0042", db->history("AU-0042"));
  ASSERT_EQ(h.calibrations.size(), 5u);
  EXPECT_EQ(h.calibrations.front().started_utc, "2026-01-15T09:00:00Z");
  ASSERT_EQ(h.parameters.size(), 9u);
  const ParameterHistory& bias_x = h.parameters[0];
  ASSERT_EQ(bias_x.name, "bias_x");
  ASSERT_EQ(bias_x.changes.size(), 4u);
  for (std::size_t c = 0; c < 4; ++c) {
    const ParameterChange& ch = bias_x.changes[c];
    const double injected = c >= 2 ? kDriftPerCalibration_ug : 0;
    // The estimated change is the injected one within its uncertainty ...
    EXPECT_NEAR(ch.delta, injected, 4 * ch.combined_sigma) << "change " << c;
    // ... which is far smaller than the drift, so the drift is unmistakable.
    EXPECT_LT(ch.combined_sigma, kDriftPerCalibration_ug / 5);
    EXPECT_EQ(ch.ageing, injected > 0)
        << "change " << c << ": delta " << ch.delta << " ± " << ch.combined_sigma;
  }
  // The other eight parameters did not change; at k = 2 chance flags are rare (the seeds
  // are fixed, so this is deterministic).
  int stable_flags = 0;
  for (std::size_t p = 1; p < h.parameters.size(); ++p) {
    for (const ParameterChange& ch : h.parameters[p].changes) stable_flags += ch.ageing ? 1 : 0;
  }
  EXPECT_LE(stable_flags, 3) << "of " << 8 * 4 << " stable changes";
  EXPECT_EQ(h.ageing_flags, 2 + stable_flags);
}

TEST(UnitHistory, UnobservableValuesAreSkippedNotCompared) {
  auto rec = [](const std::string& id, const std::string& t, nlohmann::json value) {
    CalibrationRecord r;
    r.run_id = id;
    r.started_utc = t;
    r.result = {{"parameters",
                 {{"gamma23",
                   {{"value", value},
                    {"sigma", value.is_null() ? nlohmann::json() : nlohmann::json(1.0)}}}}}};
    return r;
  };
  const UnitHistory h =
      unit_history("U", {rec("a", "1", 10.0), rec("b", "2", nullptr), rec("c", "3", 13.0)}, 2);
  const ParameterHistory& g23 = h.parameters[8];
  ASSERT_EQ(g23.name, "gamma23");
  ASSERT_EQ(g23.points.size(), 3u);
  EXPECT_FALSE(g23.points[1].value.has_value());
  ASSERT_EQ(g23.changes.size(), 1u);  // a -> c, across the calibration that could not see it
  EXPECT_EQ(g23.changes[0].from_run_id, "a");
  EXPECT_EQ(g23.changes[0].to_run_id, "c");
  EXPECT_DOUBLE_EQ(g23.changes[0].delta, 3.0);
  EXPECT_TRUE(g23.changes[0].ageing);  // 3 > 2 · sqrt(2)
  EXPECT_FALSE(unit_history("U", {rec("a", "1", 10.0), rec("c", "3", 12.0)}, 2)
                   .parameters[8]
                   .changes[0]
                   .ageing);
}

}  // namespace
}  // namespace standcal::records
