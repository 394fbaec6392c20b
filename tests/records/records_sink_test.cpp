// The daemon's records sink: a run that ends while the database is unreachable is
// recorded once it is back, from the state directory (the source of truth); nothing is
// lost and nothing is stored twice.
#include "daemon/standcald/records_sink.hpp"

#include <chrono>
#include <fstream>
#include <thread>

#include "calib/recording.hpp"
#include "tests/records/records_test_support.hpp"

namespace standcal::daemon {
namespace {

using records::open_and_migrate;

// A finished run as standcald leaves it: STATE/runs/ID/{recording.csv,result.json}.
nlohmann::json finish_run(const std::string& state_dir, const std::string& run_id,
                          std::uint64_t seed) {
  const std::string dir = state_dir + "/runs/" + run_id;
  std::filesystem::create_directories(dir);
  const Recording rec = test::simulate_calibration(default_truth(), "AU-0042", seed);
  write_recording(rec, dir + "/recording.csv");
  const nlohmann::json result =
      test::daemon_result(rec, run_id, "2026-11-21T22:36:38Z", dir + "/recording.csv");
  std::ofstream(dir + "/result.json") << result.dump(2) << "\n";
  return result;
}

// Waits (generously: a busy 2-core machine under ASan) until `done` holds.
template <typename Pred>
bool eventually(Pred done, double timeout_s = 60) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (std::chrono::steady_clock::now() < end) {
    if (done()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  return done();
}

TEST(RecordsSink, ARunFinishedWhileTheDatabaseIsUnreachableIsRecordedWhenItIsBack) {
  test::TempDir dir;
  const std::string state = dir.path() + "/state";
  // The database lives on a mount that is not there yet (an unreachable share).
  const std::string url = "sqlite://" + dir.path() + "/share/records.sqlite";
  const nlohmann::json result = finish_run(state, "20261121T223638Z-AU-0042", 1);

  RecordsSink sink(state, url);
  RecordsSyncReport r = sink.sync_once();
  EXPECT_EQ(r.recorded, 0);
  EXPECT_EQ(r.pending, 1);
  EXPECT_NE(r.error.find("20261121T223638Z-AU-0042 not yet in the records database"),
            std::string::npos)
      << r.error;
  EXPECT_TRUE(std::filesystem::exists(state + "/runs/20261121T223638Z-AU-0042/result.json"));

  std::filesystem::create_directories(dir.path() + "/share");  // the share is back
  r = sink.sync_once();
  EXPECT_EQ(r.recorded, 1);
  EXPECT_EQ(r.pending, 0);
  EXPECT_EQ(r.error, "");
  const auto stored = open_and_migrate(url)->get("20261121T223638Z-AU-0042");
  ASSERT_TRUE(stored.has_value());
  EXPECT_EQ(stored->result, result);
  EXPECT_EQ(stored->unit_serial, "AU-0042");
  EXPECT_EQ(stored->stand_id, "bench-2");
  EXPECT_EQ(stored->operator_name, "A. Lovelace");
  EXPECT_EQ(stored->origin, "daemon");

  // Nothing more to do, and a restarted daemon finds it already there.
  EXPECT_EQ(sink.sync_once().recorded, 0);
  RecordsSink restarted(state, url);
  r = restarted.sync_once();
  EXPECT_EQ(r.recorded, 0);
  EXPECT_EQ(r.already_present, 1);
  EXPECT_EQ(open_and_migrate(url)->list({}).size(), 1u);
}

TEST(RecordsSink, TheBackgroundSinkRecordsAFinishedRunWhenToldAndPendingOnesAtStart) {
  test::TempDir dir;
  const std::string state = dir.path() + "/state";
  finish_run(state, "20261120T080000Z-AU-0042", 2);  // from before the sink ran
  RecordsSink sink(state, "");                       // default: SQLite in the state directory
  EXPECT_EQ(sink.db_url(), "sqlite://" + state + "/records.sqlite");
  sink.start();
  ASSERT_TRUE(eventually([&] { return sink.last_report().recorded == 1; }))
      << sink.last_report().error;

  finish_run(state, "20261121T223638Z-AU-0042", 3);
  sink.on_event("run.progress", {{"state", "running"}});  // not the end of a run: ignored
  sink.on_event("run.state", {{"run_id", "20261121T223638Z-AU-0042"}, {"state", "done"}});
  ASSERT_TRUE(eventually([&] { return open_and_migrate(sink.db_url())->list({}).size() == 2; }));
  sink.stop();
}

TEST(RecordsSink, AnUnreadableResultIsNamedAndDoesNotHoldBackTheOthers) {
  test::TempDir dir;
  const std::string state = dir.path() + "/state";
  std::filesystem::create_directories(state + "/runs/20261101T000000Z-BROKEN");
  std::ofstream(state + "/runs/20261101T000000Z-BROKEN/result.json") << "{ truncated";
  finish_run(state, "20261121T223638Z-AU-0042", 4);
  RecordsSink sink(state, "");
  const RecordsSyncReport r = sink.sync_once();
  EXPECT_EQ(r.recorded, 1);
  EXPECT_EQ(r.pending, 1);
  EXPECT_NE(r.error.find("20261101T000000Z-BROKEN"), std::string::npos) << r.error;
}

TEST(RecordsSinkPostgres, APostgresServerDownAtRunEndIsRetriedUntilItIsBack) {
  STANDCAL_REQUIRE_POSTGRES();
  test::PostgresServer& pg = test::postgres();
  const std::string url = pg.new_database();
  test::TempDir dir;
  const std::string state = dir.path() + "/state";
  RecordsSink sink(state, url, 0.2);  // retry every 0.2 s
  sink.start();

  pg.stop();                                         // the lab server goes down ...
  finish_run(state, "20261121T223638Z-AU-0042", 5);  // ... as the run ends
  sink.on_event("run.state", {{"state", "done"}});
  ASSERT_TRUE(eventually(
      [&] { return sink.last_report().pending == 1 && !sink.last_report().error.empty(); }));
  EXPECT_NE(sink.last_report().error.find("cannot reach the records database"), std::string::npos)
      << sink.last_report().error;

  pg.start();  // ... and comes back: the retry records the run without any event
  ASSERT_TRUE(eventually([&] {
    return sink.last_report().pending == 0 && sink.last_report().error.empty();
  })) << sink.last_report().error;
  sink.stop();
  const auto stored = open_and_migrate(url)->get("20261121T223638Z-AU-0042");
  ASSERT_TRUE(stored.has_value());
  EXPECT_EQ(stored->unit_serial, "AU-0042");
}

}  // namespace
}  // namespace standcal::daemon
