// The records database on both backends: the same tests run on SQLite and on a real
// PostgreSQL server (test names with "Postgres" need it and skip when it cannot start).
#include <libpq-fe.h>
#include <sqlite3.h>

#include <mutex>
#include <thread>

#include "records/db/records_db.hpp"
#include "tests/records/records_test_support.hpp"

namespace standcal::records {
namespace {

using nlohmann::json;
using test::postgres;

CalibrationRecord sample_record(const std::string& run_id, const std::string& serial,
                                const std::string& started) {
  CalibrationRecord r;
  r.run_id = run_id;
  r.unit_serial = serial;
  r.unit_type = "NAV-3";
  r.stand_id = "bench-2";
  r.g_source = "gravimeter survey 2024";
  r.g_local_mps2 = 9.816253871;
  r.software_version = "0.1.0";
  r.config_hash = "ab12cd34";
  r.operator_name = "A. Lovelace";
  r.started_utc = started;
  r.ended_utc = "2026-11-21T23:40:00Z";
  r.program_name = "paper9";
  r.recording_path = "/var/lib/standcal/runs/" + run_id + "/recording.csv";
  r.method = "joint";
  r.result = json{{"estimator", "joint"},
                  {"parameters",
                   {{"bias_x", {{"value", 12.5}, {"sigma", 0.75}, {"unit", "ug"}}},
                    {"gamma23",
                     {{"value", nullptr},
                      {"sigma", nullptr},
                      {"unit", "arcsec"},
                      {"unobservable_reason", "not in this programme"}}}}},
                  {"chi2_dof", 1.03}};
  r.origin = "daemon";
  return r;
}

// Runs SQL directly, bypassing standcal (an older standcal wrote this database).
void raw_exec(const std::string& url, const std::string& sql) {
  if (url.rfind("postgresql://", 0) == 0) {
    PGconn* c = PQconnectdb(url.c_str());
    PGresult* r = PQexec(c, sql.c_str());
    const bool ok = PQresultStatus(r) == PGRES_COMMAND_OK || PQresultStatus(r) == PGRES_TUPLES_OK;
    const std::string why = PQerrorMessage(c);
    PQclear(r);
    PQfinish(c);
    if (!ok) throw std::runtime_error(why);
    return;
  }
  sqlite3* db = nullptr;
  sqlite3_open(url.substr(9).c_str(), &db);
  char* message = nullptr;
  const int rc = sqlite3_exec(db, sql.c_str(), nullptr, nullptr, &message);
  const std::string why = message != nullptr ? message : "";
  sqlite3_free(message);
  sqlite3_close(db);
  if (rc != SQLITE_OK) throw std::runtime_error(why);
}

// The first column of the first row of a query, as text ("" for none / NULL).
std::string raw_scalar(const std::string& url, const std::string& sql) {
  std::string out;
  if (url.rfind("postgresql://", 0) == 0) {
    PGconn* c = PQconnectdb(url.c_str());
    PGresult* r = PQexec(c, sql.c_str());
    const bool ok = PQresultStatus(r) == PGRES_TUPLES_OK;
    const std::string why = PQerrorMessage(c);
    if (ok && PQntuples(r) > 0 && !PQgetisnull(r, 0, 0)) out = PQgetvalue(r, 0, 0);
    PQclear(r);
    PQfinish(c);
    if (!ok) throw std::runtime_error(why);
    return out;
  }
  sqlite3* db = nullptr;
  sqlite3_open(url.substr(9).c_str(), &db);
  sqlite3_stmt* st = nullptr;
  if (sqlite3_prepare_v2(db, sql.c_str(), -1, &st, nullptr) != SQLITE_OK) {
    const std::string why = sqlite3_errmsg(db);
    sqlite3_close(db);
    throw std::runtime_error(why);
  }
  if (sqlite3_step(st) == SQLITE_ROW && sqlite3_column_text(st, 0) != nullptr) {
    out = reinterpret_cast<const char*>(sqlite3_column_text(st, 0));
  }
  sqlite3_finalize(st);
  sqlite3_close(db);
  return out;
}

class RecordsDbTest : public ::testing::TestWithParam<std::string> {
 protected:
  void SetUp() override {
    if (GetParam() == "postgresql") {
      STANDCAL_REQUIRE_POSTGRES();
      url_ = postgres().new_database();
    } else {
      url_ = "sqlite://" + dir_.path() + "/records.sqlite";
    }
  }
  test::TempDir dir_;
  std::string url_;
};

TEST_P(RecordsDbTest, MigrateBuildsTheNewestSchemaOnceAndAgainIsANoOp) {
  auto db = open_records_db(url_);
  EXPECT_EQ(db->backend(), GetParam());
  EXPECT_EQ(db->schema_version(), 0);
  EXPECT_EQ(db->migrate(), kSchemaVersion);
  EXPECT_EQ(db->migrate(), kSchemaVersion);
  EXPECT_EQ(open_records_db(url_)->migrate(), kSchemaVersion);
}

TEST_P(RecordsDbTest, ARecordRoundTripsWithEveryField) {
  auto db = open_and_migrate(url_);
  CalibrationRecord in =
      sample_record("20261121T223638Z-AU-0042", "AU-0042", "2026-11-21T22:36:38Z");
  in.diagnosis_verdict = "model adequate";
  in.assessment = json{{"rule", "simple acceptance, k = 2"}, {"bias_x", "pass"}};
  in.verdict = "pass";
  ASSERT_TRUE(db->insert(in));
  const auto out = db->get(in.run_id);
  ASSERT_TRUE(out.has_value());
  EXPECT_EQ(to_json(*out).dump(), [&] {
    CalibrationRecord expected = in;
    expected.recorded_utc = out->recorded_utc;  // the database's own stamp
    return to_json(expected).dump();
  }());
  EXPECT_EQ(out->recorded_utc.size(), 20u) << out->recorded_utc;
  EXPECT_DOUBLE_EQ(out->g_local_mps2, 9.816253871);
  EXPECT_FALSE(db->get("no-such-run").has_value());
}

// Text that is not UTF-8 (`standcal import --operator` typed in Latin-1, a recording's file
// name): PostgreSQL refused the row with "invalid byte sequence for encoding UTF8", SQLite
// kept bytes every JSON output shows as U+FFFD. Refused on both, naming the field, by insert
// and upsert alike, and nothing is stored.
TEST_P(RecordsDbTest, TextThatIsNotUtf8IsRefusedNamingTheField) {
  auto db = open_and_migrate(url_);
  const std::pair<const char*, std::string CalibrationRecord::*> fields[] = {
      {"run id", &CalibrationRecord::run_id},
      {"unit serial", &CalibrationRecord::unit_serial},
      {"unit type", &CalibrationRecord::unit_type},
      {"stand id", &CalibrationRecord::stand_id},
      {"programme", &CalibrationRecord::program_name},
      {"operator", &CalibrationRecord::operator_name},
      {"config hash", &CalibrationRecord::config_hash},
      {"software version", &CalibrationRecord::software_version},
      {"g source", &CalibrationRecord::g_source},
      {"recording path", &CalibrationRecord::recording_path},
      {"method", &CalibrationRecord::method},
      {"origin", &CalibrationRecord::origin}};
  for (const auto& [name, field] : fields) {
    for (const bool upsert : {false, true}) {
      CalibrationRecord r = sample_record("run-1", "AU-1", "2026-11-01T08:00:00Z");
      r.*field =
          "J. M\xFC"
          "ller";
      try {
        if (upsert)
          db->upsert(r);
        else
          db->insert(r);
        ADD_FAILURE() << "a Latin-1 " << name << " was stored";
      } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find(std::string("its ") + name +
                                             " \"J. M\xEF\xBF\xBD"
                                             "ller\" is not UTF-8 text (byte 5); the records "
                                             "database keeps UTF-8 text only"),
                  std::string::npos)
            << e.what();
      }
    }
  }
  EXPECT_TRUE(db->list({}).empty());
  CalibrationRecord r = sample_record("run-1", "AU-1", "2026-11-01T08:00:00Z");
  r.operator_name =
      "J. M\xC3\xBC"
      "ller";
  r.recording_path = "/data/\xC3\x96l.csv";
  EXPECT_TRUE(db->insert(r));
  EXPECT_EQ(db->get("run-1")->operator_name,
            "J. M\xC3\xBC"
            "ller");
}

TEST_P(RecordsDbTest, InsertKeepsTheFirstAndUpsertReplaces) {
  auto db = open_and_migrate(url_);
  CalibrationRecord r = sample_record("run-1", "AU-1", "2026-11-01T08:00:00Z");
  ASSERT_TRUE(db->insert(r));
  CalibrationRecord changed = r;
  changed.operator_name = "someone else";
  EXPECT_FALSE(db->insert(changed));
  EXPECT_EQ(db->get("run-1")->operator_name, "A. Lovelace");
  const std::string first_stamp = db->get("run-1")->recorded_utc;
  db->upsert(changed);
  EXPECT_EQ(db->get("run-1")->operator_name, "someone else");
  EXPECT_EQ(db->get("run-1")->recorded_utc, first_stamp);
  EXPECT_EQ(db->list({}).size(), 1u);
}

TEST_P(RecordsDbTest, ListFiltersBySerialTimeAndVerdictOldestFirst) {
  auto db = open_and_migrate(url_);
  db->insert(sample_record("c", "AU-1", "2026-11-03T08:00:00Z"));
  db->insert(sample_record("a", "AU-1", "2026-11-01T08:00:00Z"));
  db->insert(sample_record("b", "AU-2", "2026-11-02T23:59:59Z"));
  // A time with a zone offset is stored in UTC.
  db->insert(sample_record("d", "AU-1", "2026-11-04T01:00:00+02:00"));
  ASSERT_TRUE(db->set_verdict("c", "fail", json{{"bias_x", "fail"}}));
  EXPECT_FALSE(db->set_verdict("nope", "pass", json()));

  auto ids = [](const std::vector<CalibrationRecord>& v) {
    std::string s;
    for (const auto& r : v) s += r.run_id;
    return s;
  };
  EXPECT_EQ(ids(db->list({})), "abcd");
  EXPECT_EQ(db->get("d")->started_utc, "2026-11-03T23:00:00Z");
  EXPECT_EQ(ids(db->history("AU-1")), "acd");
  RecordFilter f;
  f.since_utc = "2026-11-02";
  f.until_utc = "2026-11-02";  // the whole day, up to 23:59:59
  EXPECT_EQ(ids(db->list(f)), "b");
  f = {};
  f.verdict = "fail";
  EXPECT_EQ(ids(db->list(f)), "c");
  EXPECT_EQ(db->get("c")->assessment["bias_x"], "fail");
  f.verdict = "none";
  EXPECT_EQ(ids(db->list(f)), "abd");
  f = {};
  f.unit_serial = "AU-1";
  f.since_utc = "2026-11-02T00:00:00Z";
  f.limit = 1;
  EXPECT_EQ(ids(db->list(f)), "c");
}

TEST_P(RecordsDbTest, AVersion1DatabaseIsMigratedKeepingItsCalibrations) {
  {
    auto old = open_records_db(url_);
    ASSERT_EQ(old->migrate_to(1), 1);
  }
  // What a standcal of schema 1 wrote: no assessment, no per-parameter rows.
  raw_exec(
      url_,
      R"(INSERT INTO calibrations (run_id, unit_serial, started_utc, result_json, recorded_utc, verdict)
    VALUES ('old-run', 'AU-7', '2025-03-01T10:00:00Z',
            '{"estimator":"joint","parameters":{"bias_x":{"value":-40.5,"sigma":1.5,"unit":"ug"},"scale_y":{"value":120,"sigma":3,"unit":"ppm"}}}',
            '2025-03-01T11:00:00Z', 'pass'))");
  auto db = open_records_db(url_);
  EXPECT_THROW(db->get("old-run"), std::runtime_error);  // not before it is migrated
  EXPECT_EQ(db->migrate(), kSchemaVersion);
  const auto r = db->get("old-run");
  ASSERT_TRUE(r.has_value());
  EXPECT_EQ(r->unit_serial, "AU-7");
  EXPECT_EQ(r->verdict, "pass");
  EXPECT_TRUE(r->assessment.is_null());
  EXPECT_FALSE(r->diagnosis_verdict.has_value());
  EXPECT_EQ(r->result["parameters"]["bias_x"]["value"], -40.5);
  // The data step of version 2 filled the per-parameter table from the stored results.
  EXPECT_EQ(
      raw_scalar(url_, "SELECT COUNT(*) FROM calibration_parameters WHERE run_id = 'old-run'"),
      "2");
  EXPECT_EQ(
      std::stod(raw_scalar(
          url_,
          "SELECT value FROM calibration_parameters WHERE run_id = 'old-run' AND name = 'bias_x'")),
      -40.5);
  EXPECT_EQ(std::stod(raw_scalar(url_,
                                 "SELECT sigma FROM calibration_parameters WHERE run_id = "
                                 "'old-run' AND name = 'scale_y'")),
            3.0);
  EXPECT_EQ(raw_scalar(url_, "SELECT COUNT(*) FROM schema_version"),
            std::to_string(kSchemaVersion));
}

TEST_P(RecordsDbTest, TwoBenchesMigratingAtOnceApplyEachVersionOnce) {
  std::vector<std::thread> benches;
  std::vector<int> versions(4, -1);
  for (int i = 0; i < 4; ++i) {
    benches.emplace_back(
        [&, i] { versions[static_cast<std::size_t>(i)] = open_records_db(url_)->migrate(); });
  }
  for (auto& t : benches) t.join();
  for (int v : versions) EXPECT_EQ(v, kSchemaVersion);
  auto db = open_and_migrate(url_);
  // Applying a version twice would have failed on its CREATE TABLE / ADD COLUMN, or
  // left two rows for it.
  EXPECT_EQ(raw_scalar(url_, "SELECT COUNT(*) FROM schema_version"),
            std::to_string(kSchemaVersion));
  EXPECT_TRUE(db->insert(sample_record("r", "AU-1", "2026-11-01")));
}

TEST_P(RecordsDbTest, ADatabaseNewerThanThisStandcalIsRefused) {
  auto db = open_and_migrate(url_);
  raw_exec(url_,
           "INSERT INTO schema_version (version, description, applied_utc) VALUES (99, 'future', "
           "'2030-01-01T00:00:00Z')");
  try {
    open_records_db(url_)->migrate();
    FAIL() << "a newer schema must be refused";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("newer than this standcal"), std::string::npos)
        << e.what();
  }
}

INSTANTIATE_TEST_SUITE_P(Sqlite, RecordsDbTest, ::testing::Values("sqlite"));
INSTANTIATE_TEST_SUITE_P(Postgres, RecordsDbTest, ::testing::Values("postgresql"));

TEST(RecordsDbOpen, AnUnreachablePostgresServerIsAClearErrorNamingIt) {
  // Port 1 on loopback: nothing listens there (tcpmux is long dead).
  const std::string url = "postgresql://standcal:secret@127.0.0.1:1/records";
  try {
    open_records_db(url);
    FAIL() << "nothing listens on port 1";
  } catch (const std::runtime_error& e) {
    const std::string what = e.what();
    EXPECT_NE(
        what.find(
            "cannot reach the records database postgresql://standcal:***@127.0.0.1:1/records"),
        std::string::npos)
        << what;
    EXPECT_EQ(what.find("secret"), std::string::npos)
        << "the password must not be printed: " << what;
  }
}

TEST(RecordsDbOpen, BadLocationsAreClearErrors) {
  EXPECT_THROW(open_records_db(""), std::runtime_error);
  EXPECT_THROW(open_records_db("mysql://host/db"), std::runtime_error);
  try {
    open_records_db("sqlite:///nonexistent-dir-for-standcal/records.sqlite");
    FAIL();
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent-dir-for-standcal/records.sqlite"),
              std::string::npos)
        << e.what();
  }
}

// Switching a new file to WAL needs it to itself, and SQLite does not run the busy handler
// for every way that switch meets another connection: benches opening a new database at
// once got "database is locked" at once (TwoBenchesMigratingAtOnce failed so within a
// 300-repeat run). A hundred new files, six benches opening each at the same moment.
TEST(RecordsDbOpen, BenchesOpeningANewFileAtOnceAllOpenItInWal) {
  test::TempDir dir;
  int refused = 0;
  std::string why;
  for (int file = 0; file < 100; ++file) {
    const std::string url = "sqlite://" + dir.path() + "/new" + std::to_string(file) + ".sqlite";
    std::vector<std::thread> benches;
    std::mutex m;
    for (int bench = 0; bench < 6; ++bench) {
      benches.emplace_back([&] {
        try {
          open_records_db(url);
        } catch (const std::exception& e) {
          const std::lock_guard<std::mutex> lock(m);
          ++refused;
          why = e.what();
        }
      });
    }
    for (auto& t : benches) t.join();
    EXPECT_EQ(raw_scalar(url, "PRAGMA journal_mode"), "wal") << url;
  }
  EXPECT_EQ(refused, 0) << "of 600 opens; the last: " << why;
}

TEST(RecordsDbOpen, APlainPathIsSqlite) {
  test::TempDir dir;
  auto db = open_and_migrate(dir.path() + "/plain.sqlite");
  EXPECT_EQ(db->backend(), "sqlite");
  EXPECT_TRUE(std::filesystem::exists(dir.path() + "/plain.sqlite"));
  EXPECT_EQ(default_db_url("/var/lib/standcal"), "sqlite:///var/lib/standcal/records.sqlite");
}

TEST(CanonicalUtc, DatesTimesAndOffsetsBecomeUtcSeconds) {
  EXPECT_EQ(canonical_utc("2026-11-21"), "2026-11-21T00:00:00Z");
  EXPECT_EQ(canonical_utc("2026-11-21", true), "2026-11-21T23:59:59Z");
  EXPECT_EQ(canonical_utc("2026-11-21T22:15:00Z"), "2026-11-21T22:15:00Z");
  EXPECT_EQ(canonical_utc("2026-11-21 22:15"), "2026-11-21T22:15:00Z");
  EXPECT_EQ(canonical_utc("2026-11-21T22:15:00.75Z"), "2026-11-21T22:15:00Z");
  EXPECT_EQ(canonical_utc("2026-01-01T01:30:00+02:00"), "2025-12-31T23:30:00Z");
  EXPECT_EQ(canonical_utc("2026-01-01T01:30:00-0130"), "2026-01-01T03:00:00Z");
  EXPECT_THROW(canonical_utc("yesterday"), std::runtime_error);
  EXPECT_THROW(canonical_utc("2026-13-01"), std::runtime_error);
  // The compact form of run ids is the same instant.
  EXPECT_EQ(canonical_utc("20261121T223638Z"), "2026-11-21T22:36:38Z");
}

// A day that is not in the calendar is an error, not the day it would roll over to
// (timegm turned 2026-02-30 into 2026-03-02: a --since filter then began two days late).
TEST(CanonicalUtc, DaysNotInTheCalendarAreRefused) {
  EXPECT_THROW(canonical_utc("2026-02-30"), std::runtime_error);
  EXPECT_THROW(canonical_utc("2026-04-31T10:00:00Z"), std::runtime_error);
  EXPECT_EQ(canonical_utc("2028-02-29"), "2028-02-29T00:00:00Z");  // a leap year
  EXPECT_THROW(canonical_utc("2026-02-29"), std::runtime_error);
}

}  // namespace
}  // namespace standcal::records
