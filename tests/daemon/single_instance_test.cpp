// One standcald per state directory and per socket (docs/daemon.md "Crash safety"): a
// second daemon refuses to start, names what is taken and by whom, and leaves the first
// one as it was: reachable, with its runs its own.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/file.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstring>

#include <filesystem>

#include "daemon_process.hpp"

using namespace standcal;
using namespace std::chrono_literals;
using nlohmann::json;
using protocol::Client;
using test::DaemonProcess;
using test::exits_with_message;
using test::socket_of;
using test::TempDir;

// A second daemon on the same state directory used to start, mark the first one's running
// run `interrupted` and serve the same runs.
TEST(DaemonSingleInstance, ASecondDaemonOnTheSameStateDirectoryRefusesNamingItAndThePid) {
  TempDir dir;
  auto first = DaemonProcess::sim(dir.path(), 50);
  Client c(socket_of(dir));
  const std::string run_id = c.call(
      "run.start", {{"program", "paper9"}, {"unit_serial", "AU-1"}, {"dwell_s", 60}})["run_id"];
  TempDir other;
  DaemonProcess second(other.path(), {"--sim", "--socket", other.path() + "/standcald.sock",
                                      "--state-dir", dir.path() + "/state", "--time-scale", "50"});
  const std::string expected = "the state directory " + dir.path() +
                               "/state is in use by another standcald (pid " +
                               std::to_string(first->pid()) + ")";
  EXPECT_TRUE(exits_with_message(second, expected)) << second.log();
  EXPECT_EQ(c.call("run.status", {{"run_id", run_id}})["state"], "running");
  c.call("run.abort");
}

// The lock is the kernel's: a killed daemon leaves none behind.
TEST(DaemonSingleInstance, AKilledDaemonsStateDirectoryCanBeTakenAtOnce) {
  TempDir dir;
  auto first = DaemonProcess::sim(dir.path(), 50);
  first->kill_now(SIGKILL);
  EXPECT_NO_THROW(DaemonProcess::sim(dir.path(), 50));
}

// A second daemon on the same socket path (another state directory) used to leave the
// first one without a socket file: no client, not even estop, could reach it.
TEST(DaemonSingleInstance, ASecondDaemonOnTheSameSocketLeavesTheFirstReachable) {
  TempDir dir;
  auto first = DaemonProcess::sim(dir.path(), 50);
  struct stat before {};
  ASSERT_EQ(::stat(socket_of(dir).c_str(), &before), 0);
  TempDir other;
  DaemonProcess second(other.path(), {"--sim", "--socket", socket_of(dir), "--state-dir",
                                      other.path() + "/state", "--time-scale", "50"});
  EXPECT_TRUE(exits_with_message(second, "another standcald (pid " + std::to_string(first->pid()) +
                                             ") owns the socket " + socket_of(dir)))
      << second.log();
  struct stat after {};
  ASSERT_EQ(::stat(socket_of(dir).c_str(), &after), 0) << "the socket file is gone";
  EXPECT_EQ(after.st_ino, before.st_ino);
  Client c(socket_of(dir));
  EXPECT_EQ(c.call("estop", json::object(), 5s)["estop"], true);
}

// Two daemons started together: the first has bound the socket but not yet called
// listen(), so a connect() to it is refused, exactly as for a stale file. The second used
// to take that for a crash's leftover, unlink it and bind its own: the first then ran on
// without a socket file. Here the test is the first daemon at that moment: it holds
// SOCKET.lock (as standcald does from before the stale check until it exits) and has
// bound the socket without listening.
TEST(DaemonSingleInstance, ASecondDaemonNeverReplacesTheSocketOfOneStillStarting) {
  TempDir dir;
  const std::string socket = socket_of(dir);
  const int lock_fd = ::open((socket + ".lock").c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0600);
  ASSERT_GE(lock_fd, 0);
  ASSERT_EQ(::flock(lock_fd, LOCK_EX | LOCK_NB), 0);
  const std::string pid = std::to_string(::getpid()) + "\n";
  ASSERT_EQ(::write(lock_fd, pid.data(), pid.size()), static_cast<ssize_t>(pid.size()));
  const int bound = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  std::strncpy(addr.sun_path, socket.c_str(), sizeof addr.sun_path - 1);
  ASSERT_EQ(::bind(bound, reinterpret_cast<const sockaddr*>(&addr), sizeof addr), 0);
  struct stat before {};
  ASSERT_EQ(::stat(socket.c_str(), &before), 0);

  TempDir other;
  DaemonProcess second(other.path(), {"--sim", "--socket", socket, "--state-dir",
                                      other.path() + "/state", "--time-scale", "50"});
  EXPECT_TRUE(exits_with_message(second, "another standcald (pid " + std::to_string(::getpid()) +
                                             ") owns the socket " + socket))
      << second.log();
  struct stat after {};
  ASSERT_EQ(::stat(socket.c_str(), &after), 0) << "the starting daemon's socket file is gone";
  EXPECT_EQ(after.st_ino, before.st_ino) << "the socket file was replaced";
  ::close(bound);
  ::close(lock_fd);
}
