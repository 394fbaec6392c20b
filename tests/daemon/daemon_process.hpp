#pragma once
// Test helper: a real standcald process in its own temporary directory, with its own
// socket; killed (and the directory removed) when the helper goes out of scope.
#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "protocol/jsonrpc/client.hpp"
#include "tests/support/temp_dir.hpp"

namespace standcal::test {

// A unique temporary directory, removed at the end.
class DaemonProcess {
 public:
  // Starts `standcald ARGS...` with stderr going to DIR/standcald.log; waits until the
  // socket answers (or the process exits).
  // `binary` and `log_name` let tests start the emulators the same way.
  DaemonProcess(const std::string& dir, std::vector<std::string> args,
                std::vector<std::string> env = {}, const std::string& binary = STANDCALD_PATH,
                const std::string& log_name = "standcald.log", const std::string& stdout_name = "")
      : dir_(dir) {
    log_path_ = dir + "/" + log_name;
    const std::string stdout_path = stdout_name.empty() ? log_path_ : dir + "/" + stdout_name;
    args.insert(args.begin(), binary);
    pid_ = ::fork();
    if (pid_ == 0) {
      ::prctl(PR_SET_PDEATHSIG, SIGKILL);  // never outlive a crashed test
      const int log = ::open(log_path_.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
      const int out = ::open(stdout_path.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
      ::dup2(log, 2);
      ::dup2(out, 1);
      for (auto& e : env) ::putenv(e.data());
      std::vector<char*> argv;
      for (auto& a : args) argv.push_back(a.data());
      argv.push_back(nullptr);
      ::execv(argv[0], argv.data());
      ::_exit(127);
    }
  }

  // The simulated backend at `time_scale`, socket DIR/standcald.sock, state DIR/state.
  static std::unique_ptr<DaemonProcess> sim(const std::string& dir, double time_scale,
                                            std::vector<std::string> extra = {}) {
    std::vector<std::string> args{
        "--sim",        "--socket",     dir + "/standcald.sock",   "--state-dir",
        dir + "/state", "--time-scale", std::to_string(time_scale)};
    args.insert(args.end(), extra.begin(), extra.end());
    auto d = std::make_unique<DaemonProcess>(dir, args);
    d->wait_ready(dir + "/standcald.sock");
    return d;
  }

  ~DaemonProcess() { kill_now(SIGKILL); }

  void wait_ready(const std::string& socket_path) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
    while (std::chrono::steady_clock::now() < deadline) {
      try {
        protocol::Client probe(socket_path, std::chrono::seconds(5));
        return;
      } catch (const std::exception&) {
      }
      if (exited()) throw std::runtime_error("standcald exited at start:\n" + log());
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    throw std::runtime_error("standcald did not answer on " + socket_path + " within 20 s:\n" +
                             log());
  }

  // Sends `sig` and waits for the exit (SIGKILL after 20 s); returns the wait status.
  int kill_now(int sig) {
    if (pid_ <= 0) return status_;
    ::kill(pid_, sig);
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
    while (!exited()) {
      if (std::chrono::steady_clock::now() > deadline) {
        ::kill(pid_, SIGKILL);
        ::waitpid(pid_, &status_, 0);
        pid_ = -1;
        break;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return status_;
  }

  bool exited() {
    if (pid_ <= 0) return true;
    if (::waitpid(pid_, &status_, WNOHANG) == pid_) {
      pid_ = -1;
      return true;
    }
    return false;
  }

  std::string log() const {
    std::ifstream in(log_path_);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
  }
  pid_t pid() const { return pid_; }
  // The wait status once exited() returned true.
  int wait_status() const { return status_; }

 private:
  std::string dir_;
  std::string log_path_;
  pid_t pid_ = -1;
  int status_ = 0;
};

// The daemon's socket inside a test's state directory.
inline std::string socket_of(const TempDir& d) { return d.path() + "/standcald.sock"; }

// The error of a call that must fail; the test fails when it succeeds (code 0 then).
inline protocol::RpcError refusal_of(protocol::Client& c, const std::string& method,
                                     const nlohmann::json& params) {
  try {
    const nlohmann::json r = c.call(method, params);
    ADD_FAILURE() << method << " accepted " << params.dump() << ": " << r.dump();
  } catch (const protocol::RpcError& e) {
    return e;
  }
  return protocol::RpcError(0, "accepted");
}

// Polls run.status until `done(status)` or the timeout; returns the last status.
inline nlohmann::json wait_run(protocol::Client& c, const std::string& run_id,
                               const std::function<bool(const nlohmann::json&)>& done,
                               std::chrono::seconds timeout = std::chrono::seconds(90)) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  nlohmann::json s;
  while (std::chrono::steady_clock::now() < deadline) {
    s = c.call("run.status", {{"run_id", run_id}});
    if (done(s)) return s;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  ADD_FAILURE() << "run " << run_id << " did not get there in time; last status " << s.dump();
  return s;
}

// The state run.status reports for `run_id` now.
inline std::string run_state_of(protocol::Client& c, const std::string& run_id) {
  return c.call("run.status", {{"run_id", run_id}})["state"];
}

// A run that will not change state any more by itself.
inline bool finished(const nlohmann::json& s) {
  const std::string st = s["state"];
  return st == "done" || st == "faulted" || st == "aborted" || st == "interrupted";
}

// Waits (up to 20 s) for `d` to exit; true when it exited 1 with `message` in its log: a
// daemon that refused to start and said why.
inline bool exits_with_message(DaemonProcess& d, const std::string& message) {
  using namespace std::chrono_literals;
  const auto deadline = std::chrono::steady_clock::now() + 20s;
  while (!d.exited() && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(10ms);
  return d.exited() && WIFEXITED(d.wait_status()) && WEXITSTATUS(d.wait_status()) == 1 &&
         d.log().find(message) != std::string::npos;
}

}  // namespace standcal::test
