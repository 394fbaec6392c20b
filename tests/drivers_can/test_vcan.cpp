// The driver on a real (virtual) CAN interface: runs where the kernel has CAN and
// vcan0 exists (`ip link add dev vcan0 type vcan && ip link set up vcan0`), skipped here.
#include <gtest/gtest.h>
#include <linux/can.h>
#include <net/if.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <thread>

#include "drivers/socketcan/socketcan_unit.hpp"

namespace standcal::drivers::can {
namespace {

// Why the vcan test cannot run here, or "" when it can.
std::string vcan_unavailable() {
  const int fd = socket(PF_CAN, SOCK_RAW, CAN_RAW);
  if (fd < 0)
    return std::string("kernel has no CAN support (socket(AF_CAN): ") + std::strerror(errno) +
           "); vcan test skipped";
  close(fd);
  if (if_nametoindex("vcan0") == 0)
    return "no vcan0 interface (ip link add dev vcan0 type vcan); vcan test skipped";
  return "";
}

TEST(Vcan, SamplesJoinedFromARealCanInterface) {
  if (const auto why = vcan_unavailable(); !why.empty()) GTEST_SKIP() << why;
  const auto layout = FrameLayout::default_layout();
  auto u = SocketCanUnit::open("vcan0", layout, {1.0, 4});
  ASSERT_TRUE(u.ok()) << u.status().message;
  auto tx = CanLink::open("vcan0", {});
  ASSERT_TRUE(tx.ok()) << tx.status().message;
  ASSERT_TRUE(u.value()->start());
  std::thread writer([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(150));
    for (std::uint64_t n = 0; n < 20; ++n)
      for (const auto& f : layout.encode({0, 9.80665, 0}, 20.0, n))
        ASSERT_TRUE(tx.value().send(f.can_id, f.data.data(), f.len));
    const std::uint8_t junk[8] = {};
    ASSERT_TRUE(tx.value().send(0x555, junk, 8));  // not in CAN_RAW_FILTER: never seen
  });
  auto r = u.value()->collect(0.6);
  writer.join();
  ASSERT_TRUE(r.ok()) << r.status().message;
  EXPECT_EQ(r.value().size(), 20U);
  EXPECT_EQ(u.value()->health().unknown_frames, 0U);
}

}  // namespace
}  // namespace standcal::drivers::can
