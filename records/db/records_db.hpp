#pragma once
// The lab's calibration records (docs/records.md): one row per calibration with its
// traceability, the fit as `standcal fit --json` emits it and the verdict. One schema,
// two backends behind one interface, chosen by URL:
//   sqlite:///var/lib/standcal/records.sqlite  or a plain path   -> SQLite (embedded)
//   postgresql://user@host:5432/standcal  (or postgres://…)       -> PostgreSQL (libpq)
// so every bench of a lab can write to one shared PostgreSQL database. Schema versions
// live in the `schema_version` table; migrate() applies the missing ones in order.
// Library target: standcal_records_db. Namespace standcal::records.
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "calib/traceability.hpp"

namespace standcal::records {

// The newest schema this build writes (migrate() brings a database up to it).
inline constexpr int kSchemaVersion = 2;

// One calibration of one unit. Times are UTC ISO-8601 "2026-11-21T22:15:00Z".
// One calibration in the database: its traceability, what it found, and how it got here.
struct CalibrationRecord : Traceability {
  std::string recording_path;
  std::string method;         // estimator: "joint", "paper-sequential", "full"
  nlohmann::json result;      // the fit as `standcal fit --json` emits it (object)
  std::string verdict;        // records::outcome_name of the overall conformity ("pass",
                              // "indeterminate", "fail"), or "" (not assessed)
  nlohmann::json assessment;  // the limits' per-parameter decision, null when none
  std::optional<std::string> diagnosis_verdict;  // model-mismatch diagnosis, if one ran
  std::string origin;        // "daemon" or "import" (how it reached the database)
  std::string recorded_utc;  // when the database first stored it (set by the database)
};

// Filters for list(); empty fields do not filter. since/until accept "2026-11-21" or a
// full "2026-11-21T22:15:00Z"; a bare date for `until` includes that whole day.
struct RecordFilter {
  std::string unit_serial;
  std::string unit_type;
  std::string since_utc;  // started_utc >= since
  std::string until_utc;  // started_utc <= until
  std::string verdict;    // a verdict ("pass", "fail", …), or "none" for not assessed
  int limit = 0;          // 0: no limit
};

class RecordsDb {
 public:
  virtual ~RecordsDb() = default;

  // "sqlite" or "postgresql".
  virtual std::string backend() const = 0;
  // Where the data is, for messages (the URL without its password).
  virtual std::string location() const = 0;

  // Applies the missing schema versions in order, each in one transaction; safe to call
  // every time and from several benches at once. Returns the version afterwards.
  int migrate() { return migrate_to(kSchemaVersion); }
  // Brings the schema up to exactly `version` (tests build older databases with it).
  virtual int migrate_to(int version) = 0;
  // 0 for an empty database.
  virtual int schema_version() = 0;

  // Stores a new record; returns false (and changes nothing) when its run id is already
  // there, so re-importing the same run is harmless.
  virtual bool insert(const CalibrationRecord& record) = 0;
  // Stores the record, replacing the one with the same run id (keeps its recorded_utc).
  virtual void upsert(const CalibrationRecord& record) = 0;
  // Records the limits' decision on a stored run; false when the run id is unknown.
  virtual bool set_verdict(const std::string& run_id, const std::string& verdict,
                           const nlohmann::json& assessment) = 0;

  virtual std::optional<CalibrationRecord> get(const std::string& run_id) = 0;
  // Oldest first (by started_utc, then run id).
  virtual std::vector<CalibrationRecord> list(const RecordFilter& filter) = 0;
  // Every calibration of one unit, oldest first.
  std::vector<CalibrationRecord> history(const std::string& unit_serial) {
    RecordFilter f;
    f.unit_serial = unit_serial;
    return list(f);
  }
};

// Whether opening may create an SQLite file: commands that only read open `existing`, so a
// mistyped path is "no such database", not a new empty file.
enum class OpenMode { create, existing };
// Opens (with OpenMode::create, for SQLite, creating) the database at `url`; does NOT
// migrate. Throws std::runtime_error naming the URL and the reason when it cannot be reached.
std::unique_ptr<RecordsDb> open_records_db(const std::string& url,
                                           OpenMode mode = OpenMode::create);
// open_records_db + migrate().
std::unique_ptr<RecordsDb> open_and_migrate(const std::string& url,
                                            OpenMode mode = OpenMode::create);

// The default database of a daemon: SQLite in its state directory.
std::string default_db_url(const std::string& state_dir);

// "2026-11-21" / "2026-11-21T22:15:00Z" / "2026-11-21T22:15:00.5+01:00" -> canonical
// "2026-11-21T21:15:00Z" (UTC, whole seconds). `end_of_day` turns a bare date into its
// last second. Throws std::runtime_error naming the text when it is not a time.
std::string canonical_utc(const std::string& text, bool end_of_day = false);

// Builds a record from a daemon's result.json (fit JSON + "traceability" block).
CalibrationRecord record_from_daemon_result(const nlohmann::json& result_json);

nlohmann::json to_json(const CalibrationRecord& r);

}  // namespace standcal::records
