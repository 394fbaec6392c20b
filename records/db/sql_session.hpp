#pragma once
// One connection to a records database, the only place where SQLite and PostgreSQL
// differ (like libmodbus's one backend struct per transport). SQL is written once with
// PostgreSQL's numbered parameters ($1, $2, …); the SQLite session maps them to ?1, ?2.
// Internal to standcal_records_db.
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace standcal::records::detail {

using SqlValue = std::optional<std::string>;  // NULL or the value as text
using SqlRow = std::vector<SqlValue>;

struct SqlResult {
  std::vector<SqlRow> rows;
  std::int64_t affected = 0;  // rows changed by INSERT/UPDATE/DELETE
};

class SqlSession {
 public:
  virtual ~SqlSession() = default;
  virtual std::string backend() const = 0;
  virtual std::string location() const = 0;
  // One statement with parameters; throws std::runtime_error naming the database.
  virtual SqlResult exec(const std::string& sql, const std::vector<SqlValue>& params = {}) = 0;
  // Several statements without parameters (migrations).
  virtual void exec_script(const std::string& sql) = 0;
  // Starts a transaction that no other writer (process or bench) runs at the same time.
  virtual void begin_exclusive() = 0;
};

// `create`: make the file when it is missing; else a missing file is "no such database".
std::unique_ptr<SqlSession> open_sqlite_session(const std::string& path, bool create);
std::unique_ptr<SqlSession> open_postgres_session(const std::string& url);

}  // namespace standcal::records::detail
