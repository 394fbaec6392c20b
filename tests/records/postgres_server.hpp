#pragma once
// Test helper: a real PostgreSQL server from Debian's `postgresql` package, in its own
// temporary directory on a free loopback port, removed at the end. PostgreSQL refuses
// to run as root, so under root the server runs as the `postgres` user (data directory
// chowned to it). When it cannot start (package missing, no such user), `skip_reason()`
// says why and the tests GTEST_SKIP with it.
#include <fcntl.h>
#include <glob.h>
#include <grp.h>
#include <libpq-fe.h>
#include <netinet/in.h>
#include <pwd.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace standcal::test {

class PostgresServer {
 public:
  PostgresServer() {
    try {
      bin_ = find_bin_dir();
      // initdb's shell steps write to /dev/null; a regular file there (left by a tool
      // that replaced it) makes them fail for the postgres user.
      if (!std::filesystem::is_character_file("/dev/null")) {
        throw std::runtime_error(
            "/dev/null is not a character device on this machine (mknod -m 666 /dev/null c 1 3)");
      }
      dir_ = make_dir();
      init_cluster();
      port_ = free_port();
      start();
    } catch (const std::exception& e) {
      skip_reason_ = e.what();
    }
  }
  ~PostgresServer() {
    stop();
    std::error_code ec;
    if (!dir_.empty()) std::filesystem::remove_all(dir_, ec);
  }
  PostgresServer(const PostgresServer&) = delete;
  PostgresServer& operator=(const PostgresServer&) = delete;

  // Empty when the server runs.
  const std::string& skip_reason() const { return skip_reason_; }
  int port() const { return port_; }

  // A new, empty database on the server; its URL.
  std::string new_database() {
    const std::string name = "standcal_test_" + std::to_string(++databases_);
    PGconn* c = PQconnectdb(url("postgres").c_str());
    PGresult* r = PQexec(c, ("CREATE DATABASE " + name).c_str());
    const bool ok = PQresultStatus(r) == PGRES_COMMAND_OK;
    const std::string why = PQerrorMessage(c);
    PQclear(r);
    PQfinish(c);
    if (!ok) throw std::runtime_error("cannot create test database " + name + ": " + why);
    return url(name);
  }
  std::string url(const std::string& database) const {
    return "postgresql://standcal@127.0.0.1:" + std::to_string(port_) + "/" + database;
  }

  // Stops the server (fast shutdown) and waits for it; the data stays.
  void stop() {
    if (pid_ <= 0) return;
    ::kill(pid_, SIGINT);
    for (int i = 0; i < 300; ++i) {  // up to 30 s on a busy machine
      if (::waitpid(pid_, nullptr, WNOHANG) == pid_) {
        pid_ = -1;
        return;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    ::kill(pid_, SIGKILL);
    ::waitpid(pid_, nullptr, 0);
    pid_ = -1;
  }

  // Starts the server on the same port and data; waits until it accepts connections.
  void start() {
    pid_ = spawn({bin_ + "/postgres", "-D", dir_ + "/data", "-p", std::to_string(port_), "-k", dir_,
                  "-c", "listen_addresses=127.0.0.1", "-c", "fsync=off", "-c",
                  "synchronous_commit=off", "-c", "full_page_writes=off"},
                 dir_ + "/server.log");
    const std::string probe = url("postgres");
    for (int i = 0; i < 600; ++i) {  // up to 60 s
      if (PQping(probe.c_str()) == PQPING_OK) return;
      if (::waitpid(pid_, nullptr, WNOHANG) == pid_) {
        pid_ = -1;
        throw std::runtime_error("postgres exited at start: " + log_tail(dir_ + "/server.log"));
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    throw std::runtime_error("postgres did not accept connections within 60 s");
  }

 private:
  static std::string find_bin_dir() {
    glob_t g{};
    std::vector<std::string> dirs;
    if (::glob("/usr/lib/postgresql/*/bin/initdb", 0, nullptr, &g) == 0) {
      for (std::size_t i = 0; i < g.gl_pathc; ++i)
        dirs.push_back(std::filesystem::path(g.gl_pathv[i]).parent_path());
    }
    ::globfree(&g);
    if (dirs.empty()) {
      throw std::runtime_error(
          "no PostgreSQL server installed (/usr/lib/postgresql/*/bin/initdb; "
          "apt-get install postgresql)");
    }
    std::sort(dirs.begin(), dirs.end());
    return dirs.back();
  }

  // Under root the server runs as `postgres`; otherwise as ourselves.
  void choose_user() {
    if (::geteuid() != 0) return;
    const passwd* pw = ::getpwnam("postgres");
    if (pw == nullptr)
      throw std::runtime_error("running as root and there is no `postgres` user to run the server");
    uid_ = pw->pw_uid;
    gid_ = pw->pw_gid;
  }

  std::string make_dir() {
    choose_user();
    std::string tmpl = (std::filesystem::temp_directory_path() / "standcal-pg-XXXXXX").string();
    if (::mkdtemp(tmpl.data()) == nullptr) throw std::runtime_error("mkdtemp failed");
    if (uid_ && ::chown(tmpl.c_str(), *uid_, *gid_) != 0)
      throw std::runtime_error("cannot chown " + tmpl);
    return tmpl;
  }

  void init_cluster() {
    const pid_t pid = spawn({bin_ + "/initdb", "-D", dir_ + "/data", "-U", "standcal",
                             "--auth=trust", "--no-sync", "-E", "UTF8", "--locale=C"},
                            dir_ + "/initdb.log");
    int status = 0;
    ::waitpid(pid, &status, 0);
    if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
      throw std::runtime_error("initdb failed: " + log_tail(dir_ + "/initdb.log"));
    }
  }

  // The last lines of a log (the directory is removed at the end, so quote it).
  static std::string log_tail(const std::string& path) {
    std::ifstream in(path);
    std::vector<std::string> lines;
    for (std::string line; std::getline(in, line);) lines.push_back(line);
    std::string out;
    for (std::size_t i = lines.size() > 4 ? lines.size() - 4 : 0; i < lines.size(); ++i)
      out += lines[i] + " | ";
    return out.empty() ? "(no output)" : out;
  }

  static int free_port() {
    const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t len = sizeof a;
    if (::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0 ||
        ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len) != 0) {
      ::close(fd);
      throw std::runtime_error("cannot find a free loopback port");
    }
    ::close(fd);
    return ntohs(a.sin_port);
  }

  // fork + (drop to postgres) + exec, output to `log`.
  pid_t spawn(std::vector<std::string> args, const std::string& log) const {
    const pid_t pid = ::fork();
    if (pid == 0) {
      const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
      ::dup2(fd, 1);
      ::dup2(fd, 2);
      if (uid_ && (::setgroups(0, nullptr) != 0 || ::setgid(*gid_) != 0 || ::setuid(*uid_) != 0))
        ::_exit(126);
      // After setuid: changing credentials clears the parent-death signal.
      ::prctl(PR_SET_PDEATHSIG, SIGKILL);  // never outlive a crashed test
      std::vector<char*> argv;
      for (auto& a : args) argv.push_back(a.data());
      argv.push_back(nullptr);
      ::execv(argv[0], argv.data());
      ::_exit(127);
    }
    if (pid < 0) throw std::runtime_error("fork failed");
    return pid;
  }

  std::string bin_;
  std::string dir_;
  std::optional<uid_t> uid_;
  std::optional<gid_t> gid_;
  int port_ = 0;
  pid_t pid_ = -1;
  int databases_ = 0;
  std::string skip_reason_;
};

}  // namespace standcal::test
