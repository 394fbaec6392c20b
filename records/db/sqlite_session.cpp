// The SQLite backend: the embedded default, one file in the daemon's state directory.
#include <sqlite3.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <stdexcept>
#include <thread>

#include "records/db/sql_session.hpp"

namespace standcal::records::detail {

namespace {

// "$12" -> "?12": SQLite's numbered parameters, so one SQL text serves both backends.
std::string numbered_parameters(const std::string& sql) {
  std::string out = sql;
  for (std::size_t i = 0; i + 1 < out.size(); ++i) {
    if (out[i] == '$' && out[i + 1] >= '0' && out[i + 1] <= '9') out[i] = '?';
  }
  return out;
}

class SqliteSession final : public SqlSession {
 public:
  SqliteSession(std::string path, bool create) : path_(std::move(path)) {
    // A command that only reads must not leave an empty database behind a mistyped path.
    if (!create && ::access(path_.c_str(), F_OK) != 0)
      throw std::runtime_error("no such database: " + path_ +
                               " (no file there; the daemon or `standcal import` creates one)");
    const int flags = SQLITE_OPEN_READWRITE | (create ? SQLITE_OPEN_CREATE : 0);
    const int rc = sqlite3_open_v2(path_.c_str(), &db_, flags, nullptr);
    if (rc != SQLITE_OK) {
      const std::string why = db_ != nullptr ? sqlite3_errmsg(db_) : sqlite3_errstr(rc);
      sqlite3_close(db_);
      db_ = nullptr;
      throw std::runtime_error("cannot open the records database " + path_ + ": " + why);
    }
    // Another process (the CLI while the daemon writes) waits instead of failing at once.
    sqlite3_busy_timeout(db_, static_cast<int>(kBusyTimeout.count()));
    try {
      // WAL: readers never block the daemon's writes; foreign keys keep parameters tied
      // to their calibration.
      use_wal();
      exec_script("PRAGMA foreign_keys=ON; PRAGMA synchronous=FULL;");
    } catch (...) {
      sqlite3_close(db_);
      throw;
    }
  }
  SqliteSession(const SqliteSession&) = delete;
  SqliteSession& operator=(const SqliteSession&) = delete;
  ~SqliteSession() override { sqlite3_close(db_); }

  std::string backend() const override { return "sqlite"; }
  std::string location() const override { return "sqlite://" + path_; }

  SqlResult exec(const std::string& sql, const std::vector<SqlValue>& params) override {
    sqlite3_stmt* stmt = nullptr;
    const std::string text = numbered_parameters(sql);
    if (sqlite3_prepare_v2(db_, text.c_str(), static_cast<int>(text.size()), &stmt, nullptr) !=
        SQLITE_OK) {
      fail("cannot prepare a statement");
    }
    try {
      bind(stmt, params);
      SqlResult result = step_all(stmt);
      sqlite3_finalize(stmt);
      return result;
    } catch (...) {
      sqlite3_finalize(stmt);
      throw;
    }
  }

  void exec_script(const std::string& sql) override {
    char* message = nullptr;
    if (sqlite3_exec(db_, sql.c_str(), nullptr, nullptr, &message) != SQLITE_OK) {
      const std::string why = message != nullptr ? message : sqlite3_errmsg(db_);
      sqlite3_free(message);
      throw std::runtime_error("records database " + path_ + ": " + why);
    }
  }

  // IMMEDIATE takes the write lock now, so two migrating processes run one after the other.
  void begin_exclusive() override { exec_script("BEGIN IMMEDIATE"); }

 private:
  static constexpr std::chrono::milliseconds kBusyTimeout{10000};

  // Switches the file to WAL, waiting for other connections as every other statement does.
  // The switch needs the file to itself, and SQLite does not run the busy handler for every
  // way it meets another connection (benches opening a new file at once got "database is
  // locked" at once), so this retries within the same time. WAL is kept in the file: after
  // the first open the mode is only read. A file that cannot be WAL (no shared memory on its
  // file system) keeps the mode SQLite leaves it in, as before.
  void use_wal() {
    using std::chrono::steady_clock;
    const auto give_up = steady_clock::now() + kBusyTimeout;
    for (;;) {
      // Each try waits on a lock only for what is left of the one timeout.
      const auto left =
          std::chrono::duration_cast<std::chrono::milliseconds>(give_up - steady_clock::now());
      sqlite3_busy_timeout(db_, static_cast<int>(std::max<std::int64_t>(left.count(), 1)));
      int rc = SQLITE_OK;
      if (journal_mode(rc) == "wal") break;
      if (rc == SQLITE_OK) {
        char* message = nullptr;
        rc = sqlite3_exec(db_, "PRAGMA journal_mode=WAL", nullptr, nullptr, &message);
        sqlite3_free(message);
        if (rc == SQLITE_OK) break;
      }
      if ((rc & 0xff) != SQLITE_BUSY || steady_clock::now() > give_up)
        fail("cannot read or set the journal mode (write-ahead logging)");
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    sqlite3_busy_timeout(db_, static_cast<int>(kBusyTimeout.count()));
  }

  // The file's journal mode ("wal", "delete", ...), or "" with `rc` set when it cannot be read.
  std::string journal_mode(int& rc) const {
    sqlite3_stmt* stmt = nullptr;
    rc = sqlite3_prepare_v2(db_, "PRAGMA journal_mode", -1, &stmt, nullptr);
    std::string mode;
    if (rc == SQLITE_OK) {
      rc = sqlite3_step(stmt);
      if (rc == SQLITE_ROW) {
        const unsigned char* v = sqlite3_column_text(stmt, 0);
        mode = v != nullptr ? reinterpret_cast<const char*>(v) : "";
        rc = SQLITE_OK;
      }
    }
    sqlite3_finalize(stmt);
    return mode;
  }

  [[noreturn]] void fail(const std::string& what) const {
    throw std::runtime_error("records database " + path_ + ": " + what + ": " +
                             sqlite3_errmsg(db_));
  }

  void bind(sqlite3_stmt* stmt, const std::vector<SqlValue>& params) const {
    for (std::size_t i = 0; i < params.size(); ++i) {
      const int index = static_cast<int>(i) + 1;
      const int rc = params[i]
                         ? sqlite3_bind_text(stmt, index, params[i]->c_str(),
                                             static_cast<int>(params[i]->size()), SQLITE_TRANSIENT)
                         : sqlite3_bind_null(stmt, index);
      if (rc != SQLITE_OK) fail("cannot bind parameter " + std::to_string(index));
    }
  }

  SqlResult step_all(sqlite3_stmt* stmt) const {
    SqlResult result;
    for (;;) {
      const int rc = sqlite3_step(stmt);
      if (rc == SQLITE_DONE) break;
      if (rc != SQLITE_ROW) fail("statement failed");
      SqlRow row;
      for (int c = 0; c < sqlite3_column_count(stmt); ++c) {
        const unsigned char* v = sqlite3_column_text(stmt, c);
        row.push_back(v != nullptr ? SqlValue(reinterpret_cast<const char*>(v)) : std::nullopt);
      }
      result.rows.push_back(std::move(row));
    }
    result.affected = sqlite3_changes64(db_);
    return result;
  }

  std::string path_;
  sqlite3* db_ = nullptr;
};

}  // namespace

std::unique_ptr<SqlSession> open_sqlite_session(const std::string& path, bool create) {
  return std::make_unique<SqliteSession>(path, create);
}

}  // namespace standcal::records::detail
