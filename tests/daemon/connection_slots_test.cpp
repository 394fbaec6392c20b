// Connection slots (docs/security.md "Connection slots"): a flood of idle connections from
// users without control must never keep root, the daemon's user or the control group
// from connecting, nor anyone from pressing `estop`. The real daemon, flooded by a child
// process that has become `nobody` (the decision itself: connection_slot_rule_test.cpp).
// max_clients is the default 256, 8 of them reserved, 16 estop-only slots beyond.
#include <grp.h>
#include <gtest/gtest.h>
#include <pwd.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstring>
#include <fstream>

#include "daemon_process.hpp"

using namespace standcal;
using namespace std::chrono_literals;
using nlohmann::json;
using protocol::Client;
using protocol::RpcError;
using test::DaemonProcess;
using test::TempDir;

namespace {

uid_t nobody_uid() {
  const passwd* pw = ::getpwnam("nobody");
  return pw != nullptr ? pw->pw_uid : 65534;
}

gid_t nobody_gid() {
  const passwd* pw = ::getpwnam("nobody");
  return pw != nullptr ? pw->pw_gid : 65534;
}

// Drops the calling (child) process to `nobody` with no supplementary group.
void become_nobody() {
  if (::setgroups(0, nullptr) != 0 || ::setgid(nobody_gid()) != 0 || ::setuid(nobody_uid()) != 0)
    ::_exit(3);
}

int connect_raw(const std::string& path) {
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  std::strncpy(addr.sun_path, path.c_str(), sizeof addr.sun_path - 1);
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd >= 0 && ::connect(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) == 0)
    return fd;
  if (fd >= 0) ::close(fd);
  return -1;
}

// A child process, as `nobody`, holding `count` idle connections (it never sends a
// byte) until the flood goes out of scope.
class IdleFlood {
 public:
  IdleFlood(const std::string& socket, int count) {
    int ready[2];
    if (::pipe(ready) != 0 || ::pipe(hold_) != 0) throw std::runtime_error("pipe failed");
    pid_ = ::fork();
    if (pid_ == 0) {
      ::close(ready[0]);
      ::close(hold_[1]);
      become_nobody();
      std::vector<int> fds;
      for (int i = 0; i < count; ++i) fds.push_back(connect_raw(socket));
      const char done = 'x';
      [[maybe_unused]] const ssize_t w = ::write(ready[1], &done, 1);
      char ignored;
      [[maybe_unused]] const ssize_t r =
          ::read(hold_[0], &ignored, 1);  // until the parent closes it
      ::_exit(0);
    }
    ::close(ready[1]);
    ::close(hold_[0]);
    char done;
    [[maybe_unused]] const ssize_t r = ::read(ready[0], &done, 1);
    ::close(ready[0]);
  }
  ~IdleFlood() {
    ::close(hold_[1]);
    int status = 0;
    ::waitpid(pid_, &status, 0);
  }

 private:
  pid_t pid_ = -1;
  int hold_[2] = {-1, -1};
};

// `call` of `method` by a fresh connection from a child that has become `nobody`: the
// answer, {"code", "message"} of an error, or {"failure"} when it could not connect.
json nobody_calls(const std::string& socket, const std::string& method) {
  int out[2];
  if (::pipe(out) != 0) throw std::runtime_error("pipe failed");
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::close(out[0]);
    become_nobody();
    json answer;
    try {
      Client c(socket, 5s);
      answer["estop_only"] = c.hello().value("estop_only", false);
      answer["result"] = c.call(method, json::object(), 10s);
    } catch (const RpcError& e) {
      answer["code"] = e.code();
      answer["message"] = e.what();
    } catch (const std::exception& e) {
      answer["failure"] = e.what();
    }
    const std::string text = answer.dump();
    [[maybe_unused]] const ssize_t w = ::write(out[1], text.data(), text.size());
    ::_exit(0);
  }
  ::close(out[1]);
  std::string text;
  char buf[4096];
  for (ssize_t n; (n = ::read(out[0], buf, sizeof buf)) > 0;)
    text.append(buf, static_cast<std::size_t>(n));
  ::close(out[0]);
  ::waitpid(pid, nullptr, 0);
  return text.empty() ? json{{"failure", "the child wrote nothing"}} : json::parse(text);
}

}  // namespace

// At 256 connections even root's estop used to be refused (-32008 at connect).
TEST(ConnectionSlots, AFloodOfIdleClientsNeverBlocksRootNorAnEmergencyStop) {
  if (::geteuid() != 0) GTEST_SKIP() << "needs root: the flood runs as user nobody";
  TempDir dir;
  ::chmod(dir.path().c_str(), 0755);  // let `nobody` reach the socket file
  const std::string socket = dir.path() + "/standcald.sock";
  const std::string config = dir.path() + "/standcald.json";
  // Everyone may connect; estop-only slots the flood takes expire after 2 s.
  std::ofstream(config) << json{
      {"socket", {{"path", socket}, {"mode", "0666"}}},
      {"state_dir", dir.path() + "/state"},
      {"client_request_timeout_s",
       2}}.dump();
  DaemonProcess daemon(dir.path(), {"--config", config, "--sim", "--time-scale", "100"});
  daemon.wait_ready(socket);

  const IdleFlood flood(socket, 300);  // more than max_clients (256) + the estop-only slots (16)
  // Root gets a reserved slot and full service.
  Client root(socket, 5s);
  EXPECT_FALSE(root.hello().contains("estop_only")) << root.hello().dump();
  const json status = root.call("status");
  EXPECT_GT(status["daemon"]["clients"].get<int>(), 256 - 8)
      << "the flood did not fill the open slots";
  EXPECT_EQ(root.call("estop", json::object(), 5s)["estop"], true);
  root.call("estop.reset");

  // Once the flood's estop-only connections timed out, anyone may press estop there too.
  json pressed;
  for (auto deadline = std::chrono::steady_clock::now() + 20s;
       std::chrono::steady_clock::now() < deadline;) {
    pressed = nobody_calls(socket, "estop");
    if (pressed.contains("result")) break;
    std::this_thread::sleep_for(200ms);
  }
  EXPECT_EQ(pressed["estop_only"], true) << pressed.dump();
  EXPECT_EQ(pressed["result"]["estop"], true) << pressed.dump();
  EXPECT_NE(daemon.log().find("EMERGENCY STOP requested by uid " + std::to_string(nobody_uid())),
            std::string::npos)
      << daemon.log();
  const json refused = nobody_calls(socket, "status");
  EXPECT_EQ(refused["code"], -32008) << refused.dump();
}
