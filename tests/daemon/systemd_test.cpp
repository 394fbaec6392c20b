// The systemd glue of the real process: READY=1 and STATUS on start, WATCHDOG=1 pings
// while both threads are alive (sd_notify to a socket the test owns, as systemd would).
#include <gtest/gtest.h>
#include <sys/socket.h>
#include <sys/un.h>

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

  DaemonProcess d(dir.path(),
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
