// The Modbus stand driver against the real emulator process over RTU, through a socat
// pty pair standing in for the RS-485 cable: motion, unit ids, corrupted frames.
#include <gtest/gtest.h>

#include <chrono>
#include <thread>

#include "drivers/modbus/modbus_stand.hpp"
#include "emulator_process.hpp"

namespace standcal::drivers::modbus {
namespace {

using test::EmulatorProcess;
using test::PtyPair;
using test::TempDir;

ModbusStandConfig rtu_config() {
  ModbusStandConfig config;
  config.timing.timeout_s = 0.3;
  config.timing.tries = 3;
  config.timing.backoff_first_s = 0.05;
  config.timing.backoff_max_s = 0.4;
  config.timing.heartbeat_period_s = 0.05;
  config.timing.heartbeat_timeout_s = 0.6;
  config.speed_dps = 30.0;
  config.ranges[1] = AxisRange::continuous_axis();  // inner: a slip ring
  return config;
}

class StandOverRtu : public ::testing::Test {
 protected:
  void SetUp() override {
    pty = std::make_unique<PtyPair>(dir.path());
    ASSERT_TRUE(pty->ready()) << "socat did not create the pty pair in " << dir.path();
    emulator = std::make_unique<EmulatorProcess>(
        "rtu:" + pty->emulator_end() + "?baud=115200&parity=N&unit=3",
        std::vector<std::string>{"--time-scale", "10", "--control", dir.file("faults")});
  }
  std::unique_ptr<ModbusStand> connect(const std::string& options) const {
    auto created = ModbusStand::create("rtu:" + pty->driver_end() + "?" + options, rtu_config());
    EXPECT_TRUE(created) << created.status().message;
    return std::move(created.value());
  }
  void inject(const std::string& lines) {
    dir.write("faults", lines);
    std::this_thread::sleep_for(std::chrono::milliseconds(250));
  }

  TempDir dir;
  std::unique_ptr<PtyPair> pty;
  std::unique_ptr<EmulatorProcess> emulator;
};

TEST_F(StandOverRtu, EnableAndMoveOverTheSerialLine) {
  auto stand = connect("baud=115200&parity=N&unit=3");
  ASSERT_TRUE(stand->configure());
  ASSERT_TRUE(stand->activate());
  ASSERT_TRUE(stand->enable(StandAxis::outer));
  ASSERT_TRUE(stand->enable(StandAxis::inner));
  for (auto axis : {StandAxis::outer, StandAxis::inner}) ASSERT_TRUE(stand->home(axis));
  const StandAxis axes[] = {StandAxis::outer, StandAxis::inner};
  ASSERT_TRUE(wait_homed(*stand, axes, 20.0, 0.01));
  ASSERT_TRUE(stand->move_to(StandAxis::outer, 45.0));
  ASSERT_TRUE(stand->move_to(StandAxis::inner, -200.0));  // continuous: −200° is 160°
  const InPositionRule rule{0.001, 0.1, 20.0, 0.01};
  auto outer = wait_in_position(*stand, StandAxis::outer, 45.0, rule);
  auto inner = wait_in_position(*stand, StandAxis::inner, 160.0, rule);
  ASSERT_TRUE(outer) << outer.status().message;
  ASSERT_TRUE(inner) << inner.status().message;
  EXPECT_NEAR(inner.value(), 160.0, rule.window_deg);
}

TEST_F(StandOverRtu, CorruptedFramesAreRetriedWithinTheBound) {
  auto stand = connect("baud=115200&parity=N&unit=3");
  ASSERT_TRUE(stand->configure());
  inject("corrupt 2\n");
  auto survived = stand->read_state(StandAxis::outer);
  ASSERT_TRUE(survived) << "2 bad frames, 3 tries: " << survived.status().message;
  EXPECT_NEAR(survived.value().angle_deg, 13.0, 0.001);
  inject("corrupt 20\n");
  auto lost = stand->read_state(StandAxis::outer);
  ASSERT_FALSE(lost);
  EXPECT_NE(lost.status().message.find("no reply from rtu:" + pty->driver_end() +
                                       " unit 3 after 3 tries"),
            std::string::npos)
      << lost.status().message;
  EXPECT_NE(lost.status().message.find("CRC"), std::string::npos) << lost.status().message;
}

TEST_F(StandOverRtu, ExceptionReplyOverRtuCarriesCodeAndMeaning) {
  auto stand = connect("baud=115200&parity=N&unit=3");
  ASSERT_TRUE(stand->configure());
  inject("exception 4\n");
  auto failed = stand->read_state(StandAxis::inner);
  ASSERT_FALSE(failed);
  EXPECT_NE(failed.status().message.find("modbus exception 4 (server device failure)"),
            std::string::npos)
      << failed.status().message;
  inject("");
  EXPECT_TRUE(stand->read_state(StandAxis::inner));
}

TEST_F(StandOverRtu, OtherUnitIdGetsNoReply) {
  auto stand = connect("baud=115200&parity=N&unit=4");
  auto configured = stand->configure();
  ASSERT_FALSE(configured);
  EXPECT_EQ(configured.kind, ErrorKind::timeout);
  EXPECT_NE(configured.message.find("unit 4 after 3 tries"), std::string::npos)
      << configured.message;
}

TEST_F(StandOverRtu, Rs485ModeOnAPortWithoutItFailsClearly) {
  auto stand = connect("baud=115200&parity=N&unit=3&rs485=1");
  auto configured = stand->configure();
  ASSERT_FALSE(configured);
  EXPECT_NE(configured.message.find("cannot switch " + pty->driver_end() + " to RS-485 mode"),
            std::string::npos)
      << configured.message;
}

}  // namespace
}  // namespace standcal::drivers::modbus
