// `standcal import`, `history` and `records` as an operator runs them: simulated
// recordings written to files, imported by the real CLI into a database, listed back.

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>

#include "calib/recording.hpp"
#include "tests/records/records_test_support.hpp"
#include "tests/support/command.hpp"
#include "tests/support/unit_static_recording.hpp"

namespace standcal::records {
namespace {

using test::standcal_cli;

class ImportTest : public ::testing::Test {
 protected:
  // A recording of unit `serial` on disk; `bias_x_shift_ug` ages the unit.
  std::string recording(const std::string& name, const std::string& serial, std::uint64_t seed,
                        double bias_x_shift_ug = 0) {
    TruthModel truth = default_truth();
    truth.unit.bias_g.x() += bias_x_shift_ug * kUg;
    const std::string path = dir_.path() + "/" + name;
    write_recording(test::simulate_calibration(truth, serial, seed), path);
    return path;
  }
  test::TempDir dir_;
  std::string db_ = "sqlite://" + dir_.path() + "/lab.sqlite";
};

TEST_F(ImportTest, ImportReFitsStoresTraceabilityAndIsIdempotent) {
  const std::string a = recording("a.csv", "AU-0100", 1);
  const std::string b = recording("b.csv", "AU-0101", 2);
  test::CommandOutcome r =
      standcal_cli("import " + a + " " + b + " --db " + db_ +
                   " --unit-type NAV-3 --stand-id old-bench --started 2025-06-01T10:00:00Z");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("2 of 2 recordings imported"), std::string::npos) << r.output;

  auto db = open_and_migrate(db_);
  const auto all = db->list({});
  ASSERT_EQ(all.size(), 2u);
  const CalibrationRecord rec = db->history("AU-0100").at(0);
  EXPECT_EQ(rec.unit_type, "NAV-3");
  EXPECT_EQ(rec.stand_id, "old-bench");
  EXPECT_EQ(rec.origin, "import");
  EXPECT_EQ(rec.started_utc, "2025-06-01T10:00:00Z");
  EXPECT_EQ(rec.method, "joint");
  EXPECT_EQ(rec.program_name, "paper9");
  EXPECT_EQ(rec.recording_path, a);
  EXPECT_EQ(rec.g_source, "recording header (g_local_mps2)");
  EXPECT_NEAR(rec.g_local_mps2, default_truth().g_local_mps2, 1e-9);
  // The stored result is the fit `standcal fit --json` gives for the same file.
  const nlohmann::json fit = fit_to_json(fit_invariant_joint(average_positions(read_recording(a))));
  EXPECT_EQ(rec.result["parameters"], fit["parameters"]);
  EXPECT_EQ(rec.result["chi2"], fit["chi2"]);

  r = standcal_cli("import " + a + " " + b + " --db " + db_ + " --started 2025-06-01T10:00:00Z");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("0 of 2 recordings imported"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("already in the database"), std::string::npos) << r.output;
  EXPECT_EQ(db->list({}).size(), 2u);
}

// The unit's known bias wander reaches the stored fit as it reaches `standcal fit` and a
// daemon run's fit (issue 21: import ignored it).
TEST_F(ImportTest, ImportWeightsWithTheUnitsKnownBiasWanderAsFitDoes) {
  const std::string a = recording("a.csv", "AU-0200", 3);
  const std::string wander = " --bias-instability-ug 20 --bias-instability-tau-s 300";
  const test::CommandOutcome r = standcal_cli("import " + a + " --db " + db_ + wander);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const CalibrationRecord rec = open_and_migrate(db_)->history("AU-0200").at(0);
  const test::CommandOutcome fit = standcal_cli("fit " + a + " --json" + wander);
  ASSERT_EQ(fit.exit_code, 0) << fit.output;
  const nlohmann::json fitted = nlohmann::json::parse(fit.output);
  EXPECT_EQ(rec.result["parameters"], fitted["parameters"]);
  // And it matters: the white-noise fit's bias sigma is smaller than the wander's.
  const nlohmann::json white =
      fit_to_json(fit_invariant_joint(average_positions(read_recording(a))));
  EXPECT_GT(rec.result["parameters"]["bias_x"]["sigma"].get<double>(),
            1.5 * white["parameters"]["bias_x"]["sigma"].get<double>());
}

// The wander the unit's static recording pins reaches the stored fit as it reaches
// `standcal fit --unit-static-recording`, with what the recording gave; the methods that model
// no wander refuse it.
TEST_F(ImportTest, ImportTakesTheWanderTheUnitsStaticRecordingPinsAsFitDoes) {
  const std::string a = recording("a.csv", "AU-0210", 3);
  const std::string still = dir_.path() + "/still.csv";
  write_recording(test::unit_static_recording(7200, 3, 60, 7), still);
  const std::string option = " --unit-static-recording " + still;
  const test::CommandOutcome r = standcal_cli("import " + a + " --db " + db_ + option);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const CalibrationRecord rec = open_and_migrate(db_)->history("AU-0210").at(0);
  EXPECT_EQ(rec.result["unit_static_recording"]["gave"], "wander") << rec.result.dump(2);
  EXPECT_EQ(rec.result["unit_static_recording"]["source"], still);
  EXPECT_EQ(rec.result["noise"]["unit_wander_from"], "static_recording") << rec.result["noise"];
  const test::CommandOutcome fit = standcal_cli("fit " + a + " --json" + option);
  ASSERT_EQ(fit.exit_code, 0) << fit.output;
  const nlohmann::json fitted = nlohmann::json::parse(fit.output);
  EXPECT_EQ(rec.result["parameters"], fitted["parameters"]);
  EXPECT_EQ(rec.result["noise"], fitted["noise"]);
  const test::CommandOutcome refused =
      standcal_cli("import " + a + " --db " + db_ + " --method paper-sequential" + option);
  EXPECT_NE(refused.exit_code, 0) << refused.output;
  EXPECT_NE(refused.output.find(
                "--unit-static-recording: the paper-sequential method models no bias wander"),
            std::string::npos)
      << refused.output;
}

TEST_F(ImportTest, ADaemonRecordingKeepsItsRunIdStartStandAndWanderSource) {
  Recording rec = test::simulate_calibration(default_truth(), "AU-0200", 3);
  rec.set_header("run_id", "20261121T223638Z-AU-0200");
  rec.set_header("started_utc", "2026-11-21T22:36:38Z");
  rec.set_header("stand_id", "bench-7");
  const std::string gave =
      "the unit's static recording /lab/still.csv (2 h static) gave its curves, to bound the "
      "wander";
  rec.set_header(kHeaderUnitWanderSource, gave);
  rec.set_header(kHeaderUnitStaticCurves, test::still_unit_curves_text());
  const std::string path = dir_.path() + "/recording.csv";
  write_recording(rec, path);
  // The full vector: paper9's 27 rows estimate a wander, where the joint fit's nine do not.
  const test::CommandOutcome r = standcal_cli("import " + path + " --db " + db_ + " --method full");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto stored = open_and_migrate(db_)->get("20261121T223638Z-AU-0200");
  ASSERT_TRUE(stored.has_value()) << r.output;
  EXPECT_EQ(stored->started_utc, "2026-11-21T22:36:38Z");
  EXPECT_EQ(stored->stand_id, "bench-7");
  // What standcald's unit.static_recording gave the run, as its run.result keeps it.
  EXPECT_EQ(stored->result.value("unit_wander_source", ""), gave) << stored->result.dump(2);
  // ... and the curves its header carries bound the wander the stored fit's sigmas allow for.
  EXPECT_EQ(stored->result["noise"].value("sigmas_allowance_allan_curves_from", ""),
            "static_recording")
      << stored->result["noise"].dump(2);
}

TEST_F(ImportTest, HistoryAndRecordsShowAnAgeingUnitAndFilterByDate) {
  const double shifts_ug[] = {0, 0, 60};
  for (int i = 0; i < 3; ++i) {
    const std::string path = recording("cal" + std::to_string(i) + ".csv", "AU-0300",
                                       static_cast<std::uint64_t>(10 + i), shifts_ug[i]);
    const test::CommandOutcome r = standcal_cli(
        "import " + path + " --db " + db_ + " --started 2026-0" + std::to_string(i + 1) + "-10");
    ASSERT_EQ(r.exit_code, 0) << r.output;
  }
  test::CommandOutcome h = standcal_cli("history AU-0300 --db " + db_);
  ASSERT_EQ(h.exit_code, 0) << h.output;
  EXPECT_NE(h.output.find("unit AU-0300: 3 calibrations"), std::string::npos) << h.output;
  EXPECT_NE(h.output.find("AGEING"), std::string::npos) << h.output;

  h = standcal_cli("history AU-0300 --json --db " + db_);
  ASSERT_EQ(h.exit_code, 0) << h.output;
  const nlohmann::json j = nlohmann::json::parse(h.output);
  EXPECT_EQ(j["calibrations"].size(), 3u);
  const nlohmann::json& bias_x_changes = j["parameters"][0]["changes"];
  ASSERT_EQ(bias_x_changes.size(), 2u);
  EXPECT_FALSE(bias_x_changes[0]["ageing"].get<bool>());
  EXPECT_TRUE(bias_x_changes[1]["ageing"].get<bool>());
  EXPECT_NEAR(bias_x_changes[1]["delta"].get<double>(), 60, 10);

  // --plot: the page plots every parameter and names the drifted one.
  const std::string page = dir_.path() + "/history.html";
  ASSERT_EQ(standcal_cli("history AU-0300 --db " + db_ + " --plot " + page).exit_code, 0);
  std::ifstream in(page);
  const std::string html((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::size_t svgs = 0;
  for (auto at = html.find("<svg"); at != std::string::npos; at = html.find("<svg", at + 1)) ++svgs;
  EXPECT_EQ(svgs, 9u);
  EXPECT_NE(html.find("AU-0300"), std::string::npos);
  EXPECT_NE(html.find("bias_x"), std::string::npos);

  const test::CommandOutcome list =
      standcal_cli("records --db " + db_ + " --since 2026-02-01 --until 2026-03-10");
  ASSERT_EQ(list.exit_code, 0) << list.output;
  EXPECT_NE(list.output.find("2026-02-10T00:00:00Z"), std::string::npos) << list.output;
  EXPECT_NE(list.output.find("2026-03-10T00:00:00Z"), std::string::npos) << list.output;
  EXPECT_EQ(list.output.find("2026-01-10"), std::string::npos) << list.output;
  EXPECT_NE(list.output.find("2 calibrations"), std::string::npos) << list.output;

  const test::CommandOutcome none = standcal_cli("history AU-9999 --db " + db_);
  EXPECT_EQ(none.exit_code, 1);
  EXPECT_NE(none.output.find("no calibrations of unit AU-9999"), std::string::npos) << none.output;
}

TEST_F(ImportTest, ABadRecordingIsNamedAndNothingIsHalfStored) {
  const std::string bad = dir_.path() + "/bad.csv";
  std::FILE* f = std::fopen(bad.c_str(), "w");
  std::fputs("# format: standcal-recording/1\nnot,a,recording\n1,2\n", f);
  std::fclose(f);
  const test::CommandOutcome r = standcal_cli("import " + bad + " --db " + db_);
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.output.find("bad.csv"), std::string::npos) << r.output;
  EXPECT_TRUE(open_and_migrate(db_)->list({}).empty());
}

// Reading commands used to open with SQLITE_OPEN_CREATE: a mistyped --db left a new empty
// database behind and answered "no calibrations" as if the lab had none.
TEST_F(ImportTest, ReadingCommandsDoNotCreateAMissingDatabase) {
  const std::string missing = dir_.path() + "/missing.sqlite";
  for (const std::string& command : {"records --db " + missing, "history AU-0100 --db " + missing,
                                     "records --db sqlite://" + missing}) {
    const test::CommandOutcome r = standcal_cli(command);
    EXPECT_EQ(r.exit_code, 1) << command << ": " << r.output;
    EXPECT_NE(r.output.find("no such database: " + missing), std::string::npos)
        << command << ": " << r.output;
    EXPECT_FALSE(std::filesystem::exists(missing)) << command << " created " << missing;
  }
  // Importing still creates the database it is told to.
  const std::string a = recording("a.csv", "AU-0100", 1);
  EXPECT_EQ(standcal_cli("import " + a + " --db " + missing).exit_code, 0);
  EXPECT_EQ(standcal_cli("records --db " + missing).exit_code, 0);
}

}  // namespace
}  // namespace standcal::records
