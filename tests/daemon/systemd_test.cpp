// The systemd glue of the real process: READY=1 and STATUS on start, WATCHDOG=1 pings
// while both threads are alive (sd_notify to a socket the test owns, as systemd would).
#include <gtest/gtest.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>

#include <fstream>
#include <string>
#include <vector>

#include "daemon_process.hpp"

using namespace std::chrono_literals;
using standcal::test::DaemonProcess;
using standcal::test::TempDir;

TEST(DaemonSystemd, NotifiesReadyAndPingsTheWatchdog) {
  TempDir dir;
  const std::string notify_path = dir.path() + "/notify.sock";
  const int fd = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  ASSERT_GE(fd, 0);
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  std::snprintf(addr.sun_path, sizeof addr.sun_path, "%s", notify_path.c_str());
  ASSERT_EQ(::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0);
  timeval tv{0, 200000};
  ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);

  DaemonProcess d(
      dir.path(),
      {"--sim", "--socket", dir.path() + "/standcald.sock", "--state-dir", dir.path() + "/state"},
      {"NOTIFY_SOCKET=" + notify_path, "WATCHDOG_USEC=400000"});
  bool ready = false;
  int pings = 0;
  const auto deadline = std::chrono::steady_clock::now() + 20s;
  while (std::chrono::steady_clock::now() < deadline && !(ready && pings >= 3)) {
    char buf[512];
    const ssize_t n = ::recv(fd, buf, sizeof buf - 1, 0);
    if (n <= 0) continue;
    const std::string msg(buf, static_cast<std::size_t>(n));
    if (msg.find("READY=1") != std::string::npos) {
      ready = true;
      EXPECT_NE(msg.find("STATUS=listening on"), std::string::npos) << msg;
    }
    if (msg.find("WATCHDOG=1") != std::string::npos) ++pings;
  }
  ::close(fd);
  EXPECT_TRUE(ready) << d.log();
  EXPECT_GE(pings, 3) << d.log();
}

namespace {

// JOURNAL_STREAM as systemd sets it when stderr is the journal: "DEVICE:INODE" of stderr.
std::string journal_stream_of(const std::string& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) return "";
  return "JOURNAL_STREAM=" + std::to_string(st.st_dev) + ":" + std::to_string(st.st_ino);
}

// Starts a simulated daemon whose stderr is DIR/standcald.log with `env`, stops it, and
// returns what it wrote there.
std::string stderr_of_daemon(const TempDir& dir, const std::vector<std::string>& env) {
  DaemonProcess d(
      dir.path(),
      {"--sim", "--socket", dir.path() + "/standcald.sock", "--state-dir", dir.path() + "/state"},
      env);
  d.wait_ready(dir.path() + "/standcald.sock");
  d.kill_now(SIGTERM);
  return d.log();
}

}  // namespace

// Under systemd (JOURNAL_STREAM names the daemon's own stderr) the log goes to the journal
// with priorities, not to stderr with a second timestamp; with the variable inherited but
// stderr redirected elsewhere, stderr it is.
TEST(DaemonSystemd, LogsToTheJournalOnlyWhenStderrIsTheJournal) {
  TempDir journal_dir;
  const std::string log = journal_dir.path() + "/standcald.log";
  { std::ofstream create(log); }
  const std::string under_systemd = stderr_of_daemon(journal_dir, {journal_stream_of(log)});
  EXPECT_EQ(under_systemd.find("starting: backend"), std::string::npos) << under_systemd;

  TempDir redirected_dir;
  const std::string elsewhere = redirected_dir.path() + "/elsewhere";
  { std::ofstream create(elsewhere); }
  const std::string redirected = stderr_of_daemon(redirected_dir, {journal_stream_of(elsewhere)});
  EXPECT_NE(redirected.find("[info] standcald "), std::string::npos) << redirected;
  EXPECT_NE(redirected.find("starting: backend sim"), std::string::npos) << redirected;
}
