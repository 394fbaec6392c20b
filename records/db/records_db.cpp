#include "records/db/records_db.hpp"

#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <stdexcept>

#include "calib/json_text.hpp"
#include "calib/parameters.hpp"
#include "calib/text.hpp"
#include "calib/utc_time.hpp"
#include "records/db/sql_session.hpp"

namespace standcal::records {

namespace {

using detail::SqlRow;
using detail::SqlSession;
using detail::SqlValue;
using nlohmann::json;

// One schema version: SQL run on both backends, then an optional data step.
struct Migration {
  int version;
  const char* description;
  const char* sql;
  void (*data_step)(SqlSession&);
};

void backfill_parameters(SqlSession& s);

// Version 1: the calibrations themselves. Types are the common subset of SQLite and
// PostgreSQL; times are canonical ISO-8601 UTC text, so text order is time order.
constexpr const char* kSchemaV1 = R"sql(
CREATE TABLE calibrations (
  run_id TEXT PRIMARY KEY,
  unit_serial TEXT NOT NULL,
  unit_type TEXT NOT NULL DEFAULT '',
  stand_id TEXT NOT NULL DEFAULT '',
  g_source TEXT NOT NULL DEFAULT '',
  g_local_mps2 DOUBLE PRECISION,
  software_version TEXT NOT NULL DEFAULT '',
  config_hash TEXT NOT NULL DEFAULT '',
  operator_name TEXT NOT NULL DEFAULT '',
  started_utc TEXT NOT NULL,
  ended_utc TEXT NOT NULL DEFAULT '',
  program_name TEXT NOT NULL DEFAULT '',
  recording_path TEXT NOT NULL DEFAULT '',
  method TEXT NOT NULL DEFAULT '',
  result_json TEXT NOT NULL,
  verdict TEXT NOT NULL DEFAULT '',
  origin TEXT NOT NULL DEFAULT '',
  recorded_utc TEXT NOT NULL
);
CREATE INDEX calibrations_unit_time ON calibrations (unit_serial, started_utc);
CREATE INDEX calibrations_time ON calibrations (started_utc);
)sql";

// Version 2: the limits' decision and the diagnosis verdict; each unit parameter in its
// own row, so a lab can chart or query parameters with plain SQL.
constexpr const char* kSchemaV2 = R"sql(
ALTER TABLE calibrations ADD COLUMN assessment_json TEXT;
ALTER TABLE calibrations ADD COLUMN diagnosis_verdict TEXT;
CREATE TABLE calibration_parameters (
  run_id TEXT NOT NULL REFERENCES calibrations (run_id) ON DELETE CASCADE,
  name TEXT NOT NULL,
  unit TEXT NOT NULL,
  value DOUBLE PRECISION,
  sigma DOUBLE PRECISION,
  PRIMARY KEY (run_id, name)
);
)sql";

const Migration kMigrations[] = {
    {1, "calibrations", kSchemaV1, nullptr},
    {2, "assessment, diagnosis verdict, calibration_parameters", kSchemaV2, backfill_parameters},
};
static_assert(std::size(kMigrations) == kSchemaVersion, "one migration per schema version");

constexpr const char* kColumns =
    "run_id, unit_serial, unit_type, stand_id, g_source, g_local_mps2, software_version, "
    "config_hash, "
    "operator_name, started_utc, ended_utc, program_name, recording_path, method, result_json, "
    "verdict, "
    "origin, recorded_utc, assessment_json, diagnosis_verdict";

std::string number_text(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

SqlValue optional_number(const json& v) {
  if (!v.is_number()) return std::nullopt;
  return number_text(v.get<double>());
}

std::vector<SqlValue> record_params(const CalibrationRecord& r) {
  return {r.run_id,
          r.unit_serial,
          r.unit_type,
          r.stand_id,
          r.g_source,
          number_text(r.g_local_mps2),
          r.software_version,
          r.config_hash,
          r.operator_name,
          canonical_utc(r.started_utc),
          r.ended_utc.empty() ? std::string() : canonical_utc(r.ended_utc),
          r.program_name,
          r.recording_path,
          r.method,
          json_text(r.result, -1),
          r.verdict,
          r.origin,
          r.recorded_utc.empty() ? utc_now_iso() : r.recorded_utc,
          r.assessment.is_null() ? SqlValue() : SqlValue(json_text(r.assessment, -1)),
          r.diagnosis_verdict};
}

CalibrationRecord record_from_row(const SqlRow& row) {
  auto text = [&](std::size_t i) { return row.at(i).value_or(""); };
  CalibrationRecord r;
  r.run_id = text(0);
  r.unit_serial = text(1);
  r.unit_type = text(2);
  r.stand_id = text(3);
  r.g_source = text(4);
  r.g_local_mps2 = row.at(5) ? std::strtod(row[5]->c_str(), nullptr) : 0.0;
  r.software_version = text(6);
  r.config_hash = text(7);
  r.operator_name = text(8);
  r.started_utc = text(9);
  r.ended_utc = text(10);
  r.program_name = text(11);
  r.recording_path = text(12);
  r.method = text(13);
  r.result = json::parse(text(14), nullptr, false);
  r.verdict = text(15);
  r.origin = text(16);
  r.recorded_utc = text(17);
  r.assessment = row.at(18) ? json::parse(*row[18], nullptr, false) : json();
  if (r.assessment.is_discarded()) r.assessment = json();
  r.diagnosis_verdict = row.at(19);
  return r;
}

// The nine parameters of a fit JSON as rows of calibration_parameters.
void write_parameters(SqlSession& s, const std::string& run_id, const json& result) {
  s.exec("DELETE FROM calibration_parameters WHERE run_id = $1", {run_id});
  const json params =
      result.is_object() ? result.value("parameters", json::object()) : json::object();
  for (std::size_t j = 0; j < kUnitParameterNames.size(); ++j) {
    const std::string name(kUnitParameterNames[j]);
    if (!params.contains(name)) continue;
    const json& p = params[name];
    s.exec(
        "INSERT INTO calibration_parameters (run_id, name, unit, value, sigma) VALUES ($1, $2, $3, "
        "$4, $5)",
        {run_id, name, std::string(kUnitParameterUnits[j]),
         optional_number(p.value("value", json())), optional_number(p.value("sigma", json()))});
  }
}

void backfill_parameters(SqlSession& s) {
  for (const SqlRow& row : s.exec("SELECT run_id, result_json FROM calibrations").rows) {
    write_parameters(s, row.at(0).value_or(""),
                     json::parse(row.at(1).value_or("{}"), nullptr, false));
  }
}

// Runs `body` in one exclusive transaction, rolling back if it throws.
template <typename Body>
auto in_transaction(SqlSession& s, Body body) {
  s.begin_exclusive();
  try {
    auto out = body();
    s.exec_script("COMMIT");
    return out;
  } catch (...) {
    try {
      s.exec_script("ROLLBACK");
    } catch (...) {  // the connection itself is gone: the first error says why
    }
    throw;
  }
}

int current_version(SqlSession& s) {
  const auto rows = s.exec("SELECT MAX(version) FROM schema_version").rows;
  return (rows.empty() || !rows[0][0]) ? 0 : std::atoi(rows[0][0]->c_str());
}

class SqlRecordsDb final : public RecordsDb {
 public:
  explicit SqlRecordsDb(std::unique_ptr<SqlSession> session) : s_(std::move(session)) {}

  std::string backend() const override { return s_->backend(); }
  std::string location() const override { return s_->location(); }

  int migrate_to(int version) override {
    if (version < 0 || version > kSchemaVersion) {
      throw std::runtime_error("no records schema version " + std::to_string(version) +
                               " (this build knows 1.." + std::to_string(kSchemaVersion) + ")");
    }
    for (;;) {
      // One version per transaction, under the writers' lock: a bench that migrates at
      // the same time waits, then finds the work done.
      const bool more = in_transaction(*s_, [&] {
        s_->exec_script(
            "CREATE TABLE IF NOT EXISTS schema_version (version INTEGER PRIMARY KEY, description "
            "TEXT NOT NULL, "
            "applied_utc TEXT NOT NULL)");
        const int have = current_version(*s_);
        if (have > kSchemaVersion) {
          throw std::runtime_error("the records database " + location() + " has schema version " +
                                   std::to_string(have) + ", newer than this standcal (" +
                                   std::to_string(kSchemaVersion) + "): update standcal");
        }
        if (have >= version) return false;
        const Migration& m = kMigrations[have];
        s_->exec_script(m.sql);
        if (m.data_step != nullptr) m.data_step(*s_);
        s_->exec(
            "INSERT INTO schema_version (version, description, applied_utc) VALUES ($1, $2, $3)",
            {std::to_string(m.version), std::string(m.description), utc_now_iso()});
        return true;
      });
      if (!more) break;
    }
    return schema_version();
  }

  int schema_version() override {
    const auto rows = s_->exec(
        backend() == "sqlite"
            ? "SELECT COUNT(*) FROM sqlite_master WHERE type = 'table' AND name = 'schema_version'"
            : "SELECT COUNT(*) FROM information_schema.tables WHERE table_name = 'schema_version' "
              "AND table_schema = current_schema()");
    if (rows.rows.empty() || rows.rows[0][0].value_or("0") == "0") return 0;
    return current_version(*s_);
  }

  bool insert(const CalibrationRecord& r) override {
    require_current();
    return in_transaction(*s_, [&] {
      const auto res =
          s_->exec(std::string("INSERT INTO calibrations (") + kColumns + ") VALUES (" +
                       placeholders() + ") ON CONFLICT (run_id) DO NOTHING",
                   record_params(checked(r)));
      if (res.affected == 0) return false;
      write_parameters(*s_, r.run_id, r.result);
      return true;
    });
  }

  void upsert(const CalibrationRecord& r) override {
    require_current();
    std::string update;
    for (const char* col : {"unit_serial", "unit_type", "stand_id", "g_source", "g_local_mps2",
                            "software_version", "config_hash", "operator_name", "started_utc",
                            "ended_utc", "program_name", "recording_path", "method", "result_json",
                            "verdict", "origin", "assessment_json", "diagnosis_verdict"}) {
      update += std::string(update.empty() ? "" : ", ") + col + " = excluded." + col;
    }
    in_transaction(*s_, [&] {
      s_->exec(std::string("INSERT INTO calibrations (") + kColumns + ") VALUES (" +
                   placeholders() + ") ON CONFLICT (run_id) DO UPDATE SET " + update,
               record_params(checked(r)));
      write_parameters(*s_, r.run_id, r.result);
      return true;
    });
  }

  bool set_verdict(const std::string& run_id, const std::string& verdict,
                   const json& assessment) override {
    require_current();
    const auto res = s_->exec(
        "UPDATE calibrations SET verdict = $1, assessment_json = $2 WHERE run_id = $3",
        {verdict, assessment.is_null() ? SqlValue() : SqlValue(json_text(assessment, -1)), run_id});
    return res.affected > 0;
  }

  std::optional<CalibrationRecord> get(const std::string& run_id) override {
    require_current();
    const auto res = s_->exec(
        std::string("SELECT ") + kColumns + " FROM calibrations WHERE run_id = $1", {run_id});
    if (res.rows.empty()) return std::nullopt;
    return record_from_row(res.rows[0]);
  }

  std::vector<CalibrationRecord> list(const RecordFilter& f) override {
    require_current();
    std::string where;
    std::vector<SqlValue> params;
    auto add = [&](const std::string& condition, const std::string& value) {
      params.push_back(value);
      where +=
          (where.empty() ? " WHERE " : " AND ") + condition + " $" + std::to_string(params.size());
    };
    if (!f.unit_serial.empty()) add("unit_serial =", f.unit_serial);
    if (!f.unit_type.empty()) add("unit_type =", f.unit_type);
    if (!f.since_utc.empty()) add("started_utc >=", canonical_utc(f.since_utc));
    if (!f.until_utc.empty()) add("started_utc <=", canonical_utc(f.until_utc, true));
    if (!f.verdict.empty()) add("verdict =", f.verdict == "none" ? std::string() : f.verdict);
    std::string sql = std::string("SELECT ") + kColumns + " FROM calibrations" + where +
                      " ORDER BY started_utc, run_id";
    if (f.limit > 0) sql += " LIMIT " + std::to_string(f.limit);
    std::vector<CalibrationRecord> out;
    for (const SqlRow& row : s_->exec(sql, params).rows) out.push_back(record_from_row(row));
    return out;
  }

 private:
  static std::string placeholders() {
    std::string p;
    for (int i = 1; i <= 20; ++i) p += (i > 1 ? ", $" : "$") + std::to_string(i);
    return p;
  }

  static const CalibrationRecord& checked(const CalibrationRecord& r) {
    if (r.run_id.empty()) throw std::runtime_error("a calibration record needs a run id");
    if (r.unit_serial.empty())
      throw std::runtime_error("calibration " + r.run_id + " has no unit serial");
    if (r.started_utc.empty())
      throw std::runtime_error("calibration " + r.run_id + " has no start time");
    require_utf8_text(r);
    return r;
  }

  // The database keeps text: PostgreSQL refuses a byte that is not UTF-8 ("invalid byte
  // sequence for encoding UTF8") and SQLite would keep it for every JSON output to print as
  // U+FFFD, so that a serial copied from `records --json` finds nothing. Refused, named.
  static void require_utf8_text(const CalibrationRecord& r) {
    const std::pair<const char*, const std::string*> fields[] = {
        {"run id", &r.run_id},           {"unit serial", &r.unit_serial},
        {"unit type", &r.unit_type},     {"stand id", &r.stand_id},
        {"programme", &r.program_name},  {"operator", &r.operator_name},
        {"config hash", &r.config_hash}, {"software version", &r.software_version},
        {"g source", &r.g_source},       {"recording path", &r.recording_path},
        {"method", &r.method},           {"origin", &r.origin}};
    for (const auto& [what, text] : fields)
      if (const auto at = first_non_utf8_byte(*text))
        throw std::runtime_error("calibration of unit " + json_text(r.unit_serial, -1) + ": its " +
                                 what + " " + json_text(*text, -1) + " is not UTF-8 text (byte " +
                                 std::to_string(*at + 1) +
                                 "); the records database keeps UTF-8 text only");
  }

  // Reads and writes assume the newest schema: an older database is migrated first.
  void require_current() {
    if (checked_current_) return;
    const int have = schema_version();
    if (have != kSchemaVersion) {
      throw std::runtime_error(
          "the records database " + location() + " has schema version " + std::to_string(have) +
          ", this standcal needs " + std::to_string(kSchemaVersion) +
          (have < kSchemaVersion ? ": migrate it first (it is done on open by standcal)" : ""));
    }
    checked_current_ = true;
  }

  std::unique_ptr<SqlSession> s_;
  bool checked_current_ = false;
};

bool starts_with(const std::string& s, const std::string& prefix) {
  return s.rfind(prefix, 0) == 0;
}

// "mysql://…": a URL of a kind we do not speak (rather than a file named so).
bool has_url_scheme(const std::string& s) {
  const std::size_t colon = s.find("://");
  if (colon == std::string::npos || colon == 0) return false;
  for (std::size_t i = 0; i < colon; ++i) {
    const char c = s[i];
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '+' && c != '.' && c != '-')
      return false;
  }
  return true;
}

}  // namespace

std::unique_ptr<RecordsDb> open_records_db(const std::string& url, OpenMode mode) {
  if (url.empty())
    throw std::runtime_error(
        "no records database given (a path, sqlite:///PATH or postgresql://…)");
  if (starts_with(url, "postgresql://") || starts_with(url, "postgres://")) {
    return std::make_unique<SqlRecordsDb>(detail::open_postgres_session(url));
  }
  std::string path = url;
  if (starts_with(path, "sqlite://")) {
    path = path.substr(9);
  } else if (starts_with(path, "sqlite:")) {
    path = path.substr(7);
  } else if (has_url_scheme(path)) {
    throw std::runtime_error("records database " + url +
                             ": unknown kind (use a path, sqlite:///PATH or postgresql://…)");
  }
  if (path.empty()) throw std::runtime_error("records database " + url + ": no file path");
  return std::make_unique<SqlRecordsDb>(
      detail::open_sqlite_session(path, mode == OpenMode::create));
}

std::unique_ptr<RecordsDb> open_and_migrate(const std::string& url, OpenMode mode) {
  auto db = open_records_db(url, mode);
  db->migrate();
  return db;
}

std::string default_db_url(const std::string& state_dir) {
  return "sqlite://" + state_dir + "/records.sqlite";
}

std::string canonical_utc(const std::string& text, bool end_of_day) {
  const auto seconds = parse_utc_s(text, UtcParseRules{end_of_day, false});
  if (!seconds) {
    throw std::runtime_error(
        "'" + text + "' is not a date or UTC time (use 2026-11-21 or 2026-11-21T22:15:00Z)");
  }
  return utc_iso(static_cast<std::time_t>(*seconds));
}

CalibrationRecord record_from_daemon_result(const json& result) {
  CalibrationRecord r;
  static_cast<Traceability&>(r) =
      traceability_from_json(result.value("traceability", json::object()));
  r.recording_path = result.value("recording_path", "");
  r.method = result.value("estimator", "");
  r.result = result;
  r.origin = "daemon";
  return r;
}

json to_json(const CalibrationRecord& r) {
  json j = traceability_to_json(r);
  j.update(json{{"recording_path", r.recording_path},
                {"method", r.method},
                {"verdict", r.verdict},
                {"origin", r.origin},
                {"recorded_utc", r.recorded_utc},
                {"result", r.result}});
  j["assessment"] = r.assessment;
  j["diagnosis_verdict"] = r.diagnosis_verdict ? json(*r.diagnosis_verdict) : json(nullptr);
  return j;
}

}  // namespace standcal::records
