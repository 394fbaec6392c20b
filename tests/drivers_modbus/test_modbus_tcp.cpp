// The Modbus stand driver against the real emulator process over TCP on loopback: the
// lifecycle, motion, ranges, the heartbeat watchdog and every injected fault.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <thread>

#include "drivers/modbus/modbus_stand.hpp"
#include "emulator_process.hpp"

namespace standcal::drivers::modbus {
namespace {

using test::EmulatorProcess;
using test::TempDir;

void sleep_s(double s) { std::this_thread::sleep_for(std::chrono::duration<double>(s)); }

// Timing for tests: short timeouts, a quick heartbeat, a watchdog of 1 s (generous for a
// loaded machine: a late heartbeat must not stop a move by accident).
ModbusStandConfig test_config() {
  ModbusStandConfig config;
  config.timing.timeout_s = 0.3;
  config.timing.tries = 3;
  config.timing.backoff_first_s = 0.05;
  config.timing.backoff_max_s = 0.4;
  config.timing.heartbeat_period_s = 0.05;
  config.timing.heartbeat_timeout_s = 1.0;
  config.ranges[0] = AxisRange::continuous_axis();                         // outer: slip ring
  config.ranges[1] = AxisRange{false, -180.0, 180.0, CableWrap::nearest};  // inner: cables
  config.speed_dps = 30.0;
  return config;
}

const InPositionRule kRule{0.001, 0.1, 20.0, 0.01};

class StandOverTcp : public ::testing::Test {
 protected:
  // The emulator runs motion 10× faster than real time so each test takes seconds.
  void start(std::vector<std::string> args = {}, ModbusStandConfig config = test_config()) {
    args.insert(args.end(), {"--time-scale", "10", "--control", dir.file("faults")});
    emulator = std::make_unique<EmulatorProcess>("tcp://127.0.0.1:0", args);
    stand = connect(config);
  }
  std::unique_ptr<ModbusStand> connect(ModbusStandConfig config = test_config()) const {
    auto created = ModbusStand::create(emulator->url() + "?unit=1", std::move(config));
    EXPECT_TRUE(created) << created.status().message;
    return std::move(created.value());
  }
  void activate_and_enable() {
    ASSERT_TRUE(stand->configure()) << "configure";
    ASSERT_TRUE(stand->activate());
    ASSERT_TRUE(stand->enable(StandAxis::outer));
    ASSERT_TRUE(stand->enable(StandAxis::inner));
  }
  // A move needs a homed axis (drivers/stand.hpp); homing takes both to 0°.
  void home_both() {
    for (auto axis : {StandAxis::outer, StandAxis::inner}) ASSERT_TRUE(stand->home(axis));
    const StandAxis axes[] = {StandAxis::outer, StandAxis::inner};
    auto homed = wait_homed(*stand, axes, 20.0, 0.01);
    ASSERT_TRUE(homed) << homed.status().message;
  }
  // Faults are injected through the control file the emulator re-reads (every 50 ms).
  void inject(const std::string& lines) {
    dir.write("faults", lines);
    sleep_s(0.25);
  }
  AxisState state(StandAxis axis) {
    auto s = stand->read_state(axis);
    EXPECT_TRUE(s) << s.status().message;
    return s ? s.value() : AxisState{};
  }

  TempDir dir;
  std::unique_ptr<EmulatorProcess> emulator;
  std::unique_ptr<ModbusStand> stand;
};

TEST_F(StandOverTcp, ConfigureReadsBothAxesAndLeavesMotionForbidden) {
  start();
  EXPECT_EQ(stand->lifecycle(), Lifecycle::unconfigured);
  ASSERT_TRUE(stand->configure());
  EXPECT_EQ(stand->lifecycle(), Lifecycle::inactive);
  const AxisState outer = state(StandAxis::outer);
  EXPECT_EQ(outer.mode, AxisMode::disabled);
  EXPECT_FALSE(outer.homed);
  EXPECT_NEAR(outer.angle_deg, 13.0, 0.001);  // power-up 12.5° read with the 0.5° unhomed error
  EXPECT_NEAR(state(StandAxis::inner).angle_deg, -32.5, 0.001);
  auto refused = stand->move_to(StandAxis::outer, 10.0);
  ASSERT_FALSE(refused);
  EXPECT_EQ(refused.kind, ErrorKind::not_allowed);
  EXPECT_NE(refused.message.find("inactive"), std::string::npos) << refused.message;
  EXPECT_GT(stand->heartbeats_written(), 0u);
}

TEST_F(StandOverTcp, HomeThenMoveReachesNormalisedTargetsInPosition) {
  start();
  activate_and_enable();
  ASSERT_TRUE(stand->home(StandAxis::outer));
  ASSERT_TRUE(stand->home(StandAxis::inner));
  for (auto axis : {StandAxis::outer, StandAxis::inner}) {
    auto homed = wait_homed(*stand, axis, 20.0);
    ASSERT_TRUE(homed) << homed.status().message;
    EXPECT_NEAR(homed.value(), 0.0, 0.001);
    EXPECT_TRUE(state(axis).homed);
  }
  // 270° on either axis is −90°: the continuous outer axis and the ±180° inner axis.
  ASSERT_TRUE(stand->move_to(StandAxis::outer, 270.0));
  ASSERT_TRUE(stand->move_to(StandAxis::inner, 270.0));
  for (auto axis : {StandAxis::outer, StandAxis::inner}) {
    auto reached = wait_in_position(*stand, axis, -90.0, kRule);
    ASSERT_TRUE(reached) << reached.status().message;
    EXPECT_NEAR(reached.value(), -90.0, kRule.window_deg);
    EXPECT_EQ(state(axis).mode, AxisMode::in_position);
  }
}

TEST_F(StandOverTcp, ContinuousAxisCrossesPlusMinus180TheShortWay) {
  start();
  activate_and_enable();
  home_both();
  ASSERT_TRUE(stand->move_to(StandAxis::outer, 170.0));
  ASSERT_TRUE(wait_in_position(*stand, StandAxis::outer, 170.0, kRule));
  ASSERT_TRUE(stand->move_to(StandAxis::outer, -170.0));
  double nearest_to_zero_deg = 180.0;
  for (int i = 0; i < 200 && state(StandAxis::outer).mode != AxisMode::in_position; ++i) {
    nearest_to_zero_deg =
        std::min(nearest_to_zero_deg, std::abs(state(StandAxis::outer).angle_deg));
    sleep_s(0.005);
  }
  auto reached = wait_in_position(*stand, StandAxis::outer, -170.0, kRule);
  ASSERT_TRUE(reached) << reached.status().message;
  EXPECT_NEAR(reached.value(), -170.0, kRule.window_deg);
  EXPECT_GT(nearest_to_zero_deg, 160.0) << "the axis went the long way, through 0°";
}

TEST_F(StandOverTcp, LimitedAxisRefusesAnAngleOutsideItsRange) {
  ModbusStandConfig config = test_config();
  config.ranges[1] = AxisRange{false, -90.0, 90.0, CableWrap::nearest};
  start({}, config);
  activate_and_enable();
  home_both();
  auto refused = stand->move_to(StandAxis::inner, 200.0);
  ASSERT_FALSE(refused);
  EXPECT_EQ(refused.kind, ErrorKind::limit);
  EXPECT_NE(refused.message.find("inner axis"), std::string::npos) << refused.message;
}

TEST_F(StandOverTcp, ControllerSoftLimitComesBackAsExceptionWithMeaning) {
  start({"--soft-limit", "inner:-45:45"});
  activate_and_enable();
  home_both();
  auto refused = stand->move_to(StandAxis::inner, 60.0);
  ASSERT_FALSE(refused);
  EXPECT_EQ(refused.kind, ErrorKind::protocol);
  EXPECT_NE(refused.message.find("modbus exception 3 (illegal data value)"), std::string::npos)
      << refused.message;
  EXPECT_EQ(stand->lifecycle(), Lifecycle::active) << "an exception is an answer, not a lost link";
}

TEST_F(StandOverTcp, MoveLongerThanTheWatchdogCompletesWhileTheDriverBeats) {
  ModbusStandConfig config = test_config();
  config.speed_dps = 7.5;  // 75 °/s at 10×: 170° take over two seconds, the watchdog is 1 s
  start({}, config);
  activate_and_enable();
  home_both();
  ASSERT_TRUE(stand->move_to(StandAxis::inner, 137.5));
  auto reached = wait_in_position(*stand, StandAxis::inner, 137.5, kRule);
  ASSERT_TRUE(reached) << reached.status().message;
  EXPECT_FALSE(state(StandAxis::inner).stopped_by_heartbeat);
}

TEST_F(StandOverTcp, HeartbeatStopHaltsMotionButLeavesAxesEnabledForTheNextConnection) {
  ModbusStandConfig slow = test_config();
  slow.speed_dps = 2.0;  // 20 °/s at 10×: a 150° move lasts 7.5 s
  start({}, slow);
  activate_and_enable();
  home_both();
  ASSERT_TRUE(stand->move_to(StandAxis::outer, 163.0));
  sleep_s(0.3);
  ASSERT_EQ(state(StandAxis::outer).mode, AxisMode::moving);
  stand.reset();  // the driver vanishes without a word: its heartbeat stops
  sleep_s(2.0);   // watchdog 1 s, then a controlled stop

  stand = connect();
  ASSERT_TRUE(stand->configure());
  const AxisState after = state(StandAxis::outer);
  EXPECT_TRUE(after.stopped_by_heartbeat);
  EXPECT_TRUE(after.enabled);
  EXPECT_EQ(after.mode, AxisMode::idle) << to_string(after.mode);
  EXPECT_EQ(after.fault_code, 0);
  EXPECT_LT(after.angle_deg, 150.0) << "it stopped short of the target";
  const double stopped_at = after.angle_deg;
  sleep_s(0.3);
  EXPECT_NEAR(state(StandAxis::outer).angle_deg, stopped_at, 0.001) << "it stays stopped";

  ASSERT_TRUE(stand->activate());  // a new connection can command again, no enable needed
  ASSERT_TRUE(stand->move_to(StandAxis::outer, 163.0));
  auto reached = wait_in_position(*stand, StandAxis::outer, 163.0, kRule);
  ASSERT_TRUE(reached) << reached.status().message;
  EXPECT_FALSE(state(StandAxis::outer).stopped_by_heartbeat);
}

TEST_F(StandOverTcp, StuckAxisFaultsWithFollowingErrorAndEnableClearsIt) {
  start();
  activate_and_enable();
  home_both();
  inject("stuck outer\n");
  const double before_deg = state(StandAxis::outer).angle_deg;
  ASSERT_TRUE(stand->move_to(StandAxis::outer, 100.0));
  auto reached = wait_in_position(*stand, StandAxis::outer, 100.0, kRule);
  ASSERT_FALSE(reached);
  EXPECT_EQ(reached.status().kind, ErrorKind::fault);
  EXPECT_NE(reached.status().message.find("code 1 (following error"), std::string::npos)
      << reached.status().message;
  const AxisState faulted = state(StandAxis::outer);
  EXPECT_EQ(faulted.mode, AxisMode::fault);
  EXPECT_NEAR(faulted.angle_deg, before_deg, 0.001) << "a stuck axis does not move";
  inject("");
  ASSERT_TRUE(stand->enable(StandAxis::outer));
  EXPECT_EQ(state(StandAxis::outer).mode, AxisMode::idle);
}

TEST_F(StandOverTcp, SlowAxisTimesOutSayingWhereItIsAndWhatItDoes) {
  start();
  activate_and_enable();
  home_both();
  inject("slow inner 50\n");
  ASSERT_TRUE(stand->move_to(StandAxis::inner, 60.0));
  InPositionRule impatient = kRule;
  impatient.timeout_s = 0.5;
  auto reached = wait_in_position(*stand, StandAxis::inner, 60.0, impatient);
  ASSERT_FALSE(reached);
  EXPECT_EQ(reached.status().kind, ErrorKind::timeout);
  const std::string& m = reached.status().message;
  EXPECT_NE(m.find("axis 2 (inner) did not reach 60.0000° within 0.5 s: at "), std::string::npos)
      << m;
  EXPECT_NE(m.find(", moving"), std::string::npos) << m;
}

TEST_F(StandOverTcp, DriveFaultIsReportedWithCodeAndText) {
  start();
  activate_and_enable();
  inject("drive_fault inner\n");
  const AxisState s = state(StandAxis::inner);
  EXPECT_EQ(s.mode, AxisMode::fault);
  EXPECT_EQ(s.fault_code, 3);
  EXPECT_EQ(s.fault_text, "drive fault");
  EXPECT_FALSE(s.enabled);
}

TEST_F(StandOverTcp, DroppedConnectionIsReopenedAndTheMoveIsStillReadNotAssumed) {
  start();
  activate_and_enable();
  home_both();
  ASSERT_TRUE(stand->move_to(StandAxis::outer, 80.0));
  EXPECT_EQ(stand->link_opens(), 1);
  inject("drop 1\n");
  auto reached = wait_in_position(*stand, StandAxis::outer, 80.0, kRule);
  ASSERT_TRUE(reached) << reached.status().message;
  EXPECT_NEAR(reached.value(), 80.0, kRule.window_deg);
  EXPECT_EQ(stand->link_opens(), 2) << "the link was re-opened once";
  EXPECT_EQ(stand->lifecycle(), Lifecycle::active) << "a retry that succeeds is not a lost link";
}

TEST_F(StandOverTcp, RepliesLaterThanTheTimeoutGiveNoReplyAfterTriesThenRecover) {
  start();
  ASSERT_TRUE(stand->configure());
  inject("delay_ms 100\n");  // shorter than the 0.3 s timeout: slow but fine
  EXPECT_TRUE(stand->read_state(StandAxis::outer));
  inject("delay_ms 500\n");
  auto lost = stand->read_state(StandAxis::outer);
  ASSERT_FALSE(lost);
  EXPECT_EQ(lost.status().kind, ErrorKind::timeout);
  EXPECT_NE(
      lost.status().message.find("no reply from " + emulator->url() + " unit 1 after 3 tries"),
      std::string::npos)
      << lost.status().message;
  EXPECT_EQ(stand->lifecycle(), Lifecycle::error);
  auto refused = stand->activate();
  EXPECT_FALSE(refused);
  inject("");
  sleep_s(2.0);  // the emulator works off the requests still queued on the old connection
  auto recovered = stand->recover();
  ASSERT_TRUE(recovered) << recovered.message;
  EXPECT_EQ(stand->lifecycle(), Lifecycle::inactive);
  EXPECT_TRUE(stand->read_state(StandAxis::inner));
}

// A controller that answers one request after the timeout (a busy PLC, a loaded bench PC)
// must cost one retry, not the link: its late reply must never be read as the answer to
// a later request, which on TCP would put every following try one reply behind.
TEST_F(StandOverTcp, OneLateReplyCostsARetryAndTheLinkStaysInStep) {
  start();
  ASSERT_TRUE(stand->configure());
  for (int i = 0; i < 5; ++i) {
    // 1.5x the 0.3 s timeout; the comment makes each control file differ, so it is re-read.
    inject("delay_ms 450 1\n# late reply " + std::to_string(i) + "\n");
    auto state = stand->read_state(StandAxis::outer);
    ASSERT_TRUE(state) << "late reply " << i << ": " << state.status().message;
    auto next = stand->read_state(StandAxis::inner);
    ASSERT_TRUE(next) << "the request after late reply " << i << ": " << next.status().message;
  }
  EXPECT_NE(stand->lifecycle(), Lifecycle::error);
}

TEST_F(StandOverTcp, ExceptionRepliesAreReportedWithCodeAndMeaning) {
  start();
  ASSERT_TRUE(stand->configure());
  inject("exception 6\n");  // every request, heartbeats included, is answered "busy"
  auto busy = stand->read_state(StandAxis::inner);
  ASSERT_FALSE(busy);
  EXPECT_EQ(busy.status().kind, ErrorKind::protocol);
  EXPECT_NE(busy.status().message.find("modbus exception 6 (server device busy) from " +
                                       emulator->url() + " unit 1 while reading inner axis status"),
            std::string::npos)
      << busy.status().message;
  EXPECT_EQ(stand->lifecycle(), Lifecycle::inactive)
      << "an exception is an answer, not a lost link";
  EXPECT_EQ(stand->link_opens(), 1) << "an exception does not re-open the link";
  inject("");
  EXPECT_TRUE(stand->read_state(StandAxis::inner));
}

TEST_F(StandOverTcp, EmergencyStopDisablesBothAxesUntilRecovered) {
  start();
  activate_and_enable();
  home_both();
  ASSERT_TRUE(stand->move_to(StandAxis::outer, 120.0));
  sleep_s(0.1);
  ASSERT_TRUE(stand->emergency_stop());
  EXPECT_EQ(stand->lifecycle(), Lifecycle::error);
  for (auto axis : {StandAxis::outer, StandAxis::inner}) {
    const AxisState s = state(axis);
    EXPECT_TRUE(s.estop);
    EXPECT_FALSE(s.enabled);
    EXPECT_EQ(s.mode, AxisMode::disabled);
  }
  EXPECT_EQ(stand->move_to(StandAxis::outer, 0.0).kind, ErrorKind::estop);
  // A second connection sees the latch too and cannot activate.
  auto other = connect();
  ASSERT_TRUE(other->configure());
  EXPECT_EQ(other->lifecycle(), Lifecycle::error);
  other.reset();
  ASSERT_TRUE(stand->recover());
  ASSERT_TRUE(stand->activate());
  ASSERT_TRUE(stand->enable(StandAxis::outer));
  EXPECT_FALSE(state(StandAxis::outer).estop);
}

TEST_F(StandOverTcp, LabSpecificMapWithLowWordFirstAndScatteredRegisters) {
  // The same JSON configures both ends, as a lab would match its controller's manual.
  const char* map_json = R"({
    "word_order": "low_first", "angle_lsb_deg": 0.001, "speed_lsb_dps": 0.1,
    "registers": {"heartbeat": 40, "heartbeat_timeout_ms": 41, "global_command": 42, "global_flags": 50,
                  "map_version": 51,
                  "outer": {"target": 500, "speed": 510, "command": 520,
                            "state": 600, "flags": 601, "angle": 602, "fault": 604, "command_count": 605},
                  "inner": {"target": 700, "speed": 702, "command": 703,
                            "state": 800, "flags": 810, "angle": 820, "fault": 830, "command_count": 831}}})";
  dir.write("map.json", map_json);
  auto parsed = parse_config(nlohmann::json::parse(map_json));
  ASSERT_TRUE(parsed) << parsed.status().message;
  ModbusStandConfig config = parsed.value();
  const ModbusStandConfig timing = test_config();
  config.timing = timing.timing;
  config.ranges = timing.ranges;
  start({"--config", dir.file("map.json")}, config);
  activate_and_enable();
  EXPECT_NEAR(state(StandAxis::inner).angle_deg, -32.5, 0.002);
  home_both();
  ASSERT_TRUE(stand->move_to(StandAxis::outer, -45.25));
  ASSERT_TRUE(stand->move_to(StandAxis::inner, 33.125));
  InPositionRule coarse = kRule;
  coarse.window_deg = 0.002;  // one count is 0.001° here
  auto outer = wait_in_position(*stand, StandAxis::outer, -45.25, coarse);
  auto inner = wait_in_position(*stand, StandAxis::inner, 33.125, coarse);
  ASSERT_TRUE(outer) << outer.status().message;
  ASSERT_TRUE(inner) << inner.status().message;
}

TEST(StandOverTcpWithoutServer, NobodyListeningGivesNoReplyAfterTries) {
  // Find a port with nobody on it: start an emulator, note its port, stop it.
  std::string url;
  {
    EmulatorProcess gone("tcp://127.0.0.1:0", {});
    url = gone.url();
  }
  ModbusStandConfig config = test_config();
  auto stand = ModbusStand::create(url, config);
  ASSERT_TRUE(stand);
  auto configured = stand.value()->configure();
  ASSERT_FALSE(configured);
  EXPECT_EQ(configured.kind, ErrorKind::link);
  EXPECT_NE(configured.message.find("no reply from " + url + " unit 1 after 3 tries"),
            std::string::npos)
      << configured.message;
  EXPECT_EQ(stand.value()->lifecycle(), Lifecycle::unconfigured);
}

}  // namespace
}  // namespace standcal::drivers::modbus
