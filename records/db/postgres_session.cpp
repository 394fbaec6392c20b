// The PostgreSQL backend: one database shared by every bench of a lab (libpq).
#include <libpq-fe.h>

#include <cstdlib>
#include <stdexcept>

#include "records/db/sql_session.hpp"

namespace standcal::records::detail {

namespace {

// Any number: the advisory lock every migrating bench takes, so schema versions are
// applied once even when several daemons start together.
constexpr const char* kMigrationLockKey = "7359620041";

// "postgresql://user:secret@host/db" -> "postgresql://user:***@host/db".
std::string without_password(const std::string& url) {
  const std::size_t start = url.find("://");
  if (start == std::string::npos) return url;
  const std::size_t at = url.find('@', start + 3);
  const std::size_t colon = url.find(':', start + 3);
  const std::size_t slash = url.find('/', start + 3);
  if (at == std::string::npos || colon == std::string::npos || colon > at || slash < at) return url;
  return url.substr(0, colon + 1) + "***" + url.substr(at);
}

// libpq's messages span lines ("…failed: Connection refused\n\tIs the server running…");
// an operator's error is one line.
std::string trimmed(const std::string& s) {
  std::string out;
  for (char c : s) {
    if (c == '\n' || c == '\t') {
      if (!out.empty() && out.back() != ' ') out += out.back() == ';' ? " " : "; ";
    } else {
      out += c;
    }
  }
  while (!out.empty() && (out.back() == ' ' || out.back() == ';')) out.pop_back();
  return out;
}

class PostgresSession final : public SqlSession {
 public:
  explicit PostgresSession(const std::string& url) : location_(without_password(url)) {
    // connect_timeout: an unreachable server is an error in seconds, not minutes.
    const char* keys[] = {"dbname", "connect_timeout", "application_name", nullptr};
    const char* values[] = {url.c_str(), "5", "standcal", nullptr};
    conn_ = PQconnectdbParams(keys, values, 1);
    if (conn_ == nullptr || PQstatus(conn_) != CONNECTION_OK) {
      const std::string why = conn_ != nullptr ? trimmed(PQerrorMessage(conn_)) : "out of memory";
      PQfinish(conn_);
      throw std::runtime_error("cannot reach the records database " + location_ + ": " + why);
    }
    exec_script("SET client_min_messages = warning");  // no NOTICEs on stderr
  }
  PostgresSession(const PostgresSession&) = delete;
  PostgresSession& operator=(const PostgresSession&) = delete;
  ~PostgresSession() override { PQfinish(conn_); }

  std::string backend() const override { return "postgresql"; }
  std::string location() const override { return location_; }

  SqlResult exec(const std::string& sql, const std::vector<SqlValue>& params) override {
    std::vector<const char*> values;
    for (const SqlValue& p : params) values.push_back(p ? p->c_str() : nullptr);
    PGresult* res = PQexecParams(conn_, sql.c_str(), static_cast<int>(values.size()), nullptr,
                                 values.data(), nullptr, nullptr, 0);
    check(res);
    SqlResult result;
    for (int r = 0; r < PQntuples(res); ++r) {
      SqlRow row;
      for (int c = 0; c < PQnfields(res); ++c) {
        row.push_back(PQgetisnull(res, r, c) ? std::nullopt : SqlValue(PQgetvalue(res, r, c)));
      }
      result.rows.push_back(std::move(row));
    }
    const char* tuples = PQcmdTuples(res);
    result.affected = (tuples != nullptr && *tuples != '\0') ? std::atoll(tuples) : 0;
    PQclear(res);
    return result;
  }

  void exec_script(const std::string& sql) override {
    PGresult* res = PQexec(conn_, sql.c_str());
    check(res);
    PQclear(res);
  }

  void begin_exclusive() override {
    exec_script(std::string("BEGIN; SELECT pg_advisory_xact_lock(") + kMigrationLockKey + ")");
  }

 private:
  // Throws (after freeing `res`) unless the statement succeeded.
  void check(PGresult* res) const {
    const ExecStatusType status = PQresultStatus(res);
    if (status == PGRES_COMMAND_OK || status == PGRES_TUPLES_OK) return;
    std::string why = res != nullptr ? trimmed(PQresultErrorMessage(res)) : "";
    if (why.empty()) why = trimmed(PQerrorMessage(conn_));
    PQclear(res);
    throw std::runtime_error("records database " + location_ + ": " + why);
  }

  std::string location_;
  PGconn* conn_ = nullptr;
};

}  // namespace

std::unique_ptr<SqlSession> open_postgres_session(const std::string& url) {
  return std::make_unique<PostgresSession>(url);
}

}  // namespace standcal::records::detail
