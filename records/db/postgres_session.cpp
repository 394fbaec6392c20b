// The PostgreSQL backend: one database shared by every bench of a lab (libpq).
#include <dlfcn.h>
#include <libpq-fe.h>

#include <cstdlib>
#include <stdexcept>
#include <string>

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

// libpq is opened on first use, not linked: it brings about twenty libraries (Kerberos,
// LDAP, GnuTLS...) whose loading cost every `standcal` command 12 ms of start-up, and
// only the PostgreSQL records backend needs it (docs/performance.md).
struct LibPq {
  decltype(&PQconnectdbParams) connectdb_params;
  decltype(&PQstatus) status;
  decltype(&PQerrorMessage) error_message;
  decltype(&PQfinish) finish;
  decltype(&PQexecParams) exec_params;
  decltype(&PQntuples) ntuples;
  decltype(&PQnfields) nfields;
  decltype(&PQgetisnull) getisnull;
  decltype(&PQgetvalue) getvalue;
  decltype(&PQcmdTuples) cmd_tuples;
  decltype(&PQclear) clear;
  decltype(&PQexec) exec;
  decltype(&PQresultStatus) result_status;
  decltype(&PQresultErrorMessage) result_error_message;
};

constexpr const char* kLibPqSoname = "libpq.so.5";

template <typename F>
void bind(void* handle, F& function, const char* name) {
  function = reinterpret_cast<F>(::dlsym(handle, name));
  if (function == nullptr)
    throw std::runtime_error(std::string("the PostgreSQL client library ") + kLibPqSoname +
                             " has no " + name + " (too old a libpq?)");
}

LibPq load_libpq() {
  void* handle = ::dlopen(kLibPqSoname, RTLD_NOW | RTLD_LOCAL);
  if (handle == nullptr)
    throw std::runtime_error(
        std::string("the PostgreSQL records backend needs the client library ") + kLibPqSoname +
        " (Debian package libpq5): " + ::dlerror());
  LibPq pq{};
  bind(handle, pq.connectdb_params, "PQconnectdbParams");
  bind(handle, pq.status, "PQstatus");
  bind(handle, pq.error_message, "PQerrorMessage");
  bind(handle, pq.finish, "PQfinish");
  bind(handle, pq.exec_params, "PQexecParams");
  bind(handle, pq.ntuples, "PQntuples");
  bind(handle, pq.nfields, "PQnfields");
  bind(handle, pq.getisnull, "PQgetisnull");
  bind(handle, pq.getvalue, "PQgetvalue");
  bind(handle, pq.cmd_tuples, "PQcmdTuples");
  bind(handle, pq.clear, "PQclear");
  bind(handle, pq.exec, "PQexec");
  bind(handle, pq.result_status, "PQresultStatus");
  bind(handle, pq.result_error_message, "PQresultErrorMessage");
  return pq;  // the handle stays open for the life of the process
}

const LibPq& libpq() {
  static const LibPq pq = load_libpq();
  return pq;
}

class PostgresSession final : public SqlSession {
 public:
  explicit PostgresSession(const std::string& url) : location_(without_password(url)) {
    // connect_timeout: an unreachable server is an error in seconds, not minutes.
    const char* keys[] = {"dbname", "connect_timeout", "application_name", nullptr};
    const char* values[] = {url.c_str(), "5", "standcal", nullptr};
    conn_ = libpq().connectdb_params(keys, values, 1);
    if (conn_ == nullptr || libpq().status(conn_) != CONNECTION_OK) {
      const std::string why =
          conn_ != nullptr ? trimmed(libpq().error_message(conn_)) : "out of memory";
      libpq().finish(conn_);
      throw std::runtime_error("cannot reach the records database " + location_ + ": " + why);
    }
    exec_script("SET client_min_messages = warning");  // no NOTICEs on stderr
  }
  PostgresSession(const PostgresSession&) = delete;
  PostgresSession& operator=(const PostgresSession&) = delete;
  ~PostgresSession() override { libpq().finish(conn_); }

  std::string backend() const override { return "postgresql"; }
  std::string location() const override { return location_; }

  SqlResult exec(const std::string& sql, const std::vector<SqlValue>& params) override {
    std::vector<const char*> values;
    for (const SqlValue& p : params) values.push_back(p ? p->c_str() : nullptr);
    PGresult* res = libpq().exec_params(conn_, sql.c_str(), static_cast<int>(values.size()),
                                        nullptr, values.data(), nullptr, nullptr, 0);
    check(res);
    SqlResult result;
    for (int r = 0; r < libpq().ntuples(res); ++r) {
      SqlRow row;
      for (int c = 0; c < libpq().nfields(res); ++c) {
        row.push_back(libpq().getisnull(res, r, c) ? std::nullopt
                                                   : SqlValue(libpq().getvalue(res, r, c)));
      }
      result.rows.push_back(std::move(row));
    }
    const char* tuples = libpq().cmd_tuples(res);
    result.affected = (tuples != nullptr && *tuples != '\0') ? std::atoll(tuples) : 0;
    libpq().clear(res);
    return result;
  }

  void exec_script(const std::string& sql) override {
    PGresult* res = libpq().exec(conn_, sql.c_str());
    check(res);
    libpq().clear(res);
  }

  void begin_exclusive() override {
    exec_script(std::string("BEGIN; SELECT pg_advisory_xact_lock(") + kMigrationLockKey + ")");
  }

 private:
  // Throws (after freeing `res`) unless the statement succeeded.
  void check(PGresult* res) const {
    const ExecStatusType status = libpq().result_status(res);
    if (status == PGRES_COMMAND_OK || status == PGRES_TUPLES_OK) return;
    std::string why = res != nullptr ? trimmed(libpq().result_error_message(res)) : "";
    if (why.empty()) why = trimmed(libpq().error_message(conn_));
    libpq().clear(res);
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
