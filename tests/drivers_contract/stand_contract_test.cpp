// The Stand contract (issue 18, item 1): the same cases over every backend — the simulated
// stand and the Modbus stand talking to the real emulator process on loopback. The
// lifecycle lives once in drivers/stand; these cases are what any new backend must pass.
#include <gtest/gtest.h>

#include <chrono>
#include <memory>
#include <string>
#include <thread>

#include "drivers/modbus/modbus_stand.hpp"
#include "drivers/sim/sim_backend.hpp"
#include "drivers/stand.hpp"
#include "tests/drivers_modbus/emulator_process.hpp"
#include "tests/support/temp_dir.hpp"

namespace standcal::drivers {
namespace {

void sleep_s(double s) { std::this_thread::sleep_for(std::chrono::duration<double>(s)); }

// The simulated stand, 20× faster than real time.
class SimStandBackend {
 public:
  static constexpr bool kHasLink = false;
  SimStandBackend() {
    SimBackendConfig config;
    config.time_scale = 20;
    config.move_rate_deg_s = 30;
    backend_ = make_sim_backend(config);
  }
  Stand& stand() { return *backend_.stand; }
  // The stand's driver is gone and a new one connects to the same controller: the sim has
  // no link, so there is nothing to reconnect.
  void reconnect() {}

 private:
  SimBackend backend_;
};

// ModbusStand against standcal-stand-emu on loopback, its motion 10× faster than real time.
class ModbusStandBackend {
 public:
  static constexpr bool kHasLink = true;
  ModbusStandBackend()
      : emulator_("tcp://127.0.0.1:0", {"--time-scale", "10", "--control", dir_.file("faults")}) {
    reconnect();
  }
  Stand& stand() { return *stand_; }
  void reconnect() {
    stand_.reset();  // its heartbeat stops here
    modbus::ModbusStandConfig config;
    config.timing.timeout_s = 0.3;
    config.timing.tries = 3;
    config.timing.backoff_first_s = 0.05;
    config.timing.heartbeat_period_s = 0.05;
    config.timing.heartbeat_timeout_s = 1.0;
    config.speed_dps = 3.0;  // 30 °/s at 10×
    auto created = modbus::ModbusStand::create(emulator_.url() + "?unit=1", config);
    if (!created) throw std::runtime_error(created.status().message);
    stand_ = std::move(created.value());
  }

 private:
  test::TempDir dir_;
  test::EmulatorProcess emulator_;
  std::unique_ptr<modbus::ModbusStand> stand_;
};

constexpr StandAxis kAxes[] = {StandAxis::outer, StandAxis::inner};

template <class Backend>
class StandContract : public ::testing::Test {
 protected:
  Stand& stand() { return backend_.stand(); }
  void make_active_and_enabled() {
    ASSERT_TRUE(stand().configure());
    ASSERT_TRUE(stand().activate());
    for (StandAxis a : kAxes) ASSERT_TRUE(stand().enable(a));
  }
  void make_ready_to_move() {
    make_active_and_enabled();
    for (StandAxis a : kAxes) ASSERT_TRUE(stand().home(a));
    const auto homed = wait_homed(stand(), kAxes, 30.0, 0.01);
    ASSERT_TRUE(homed) << homed.status().message;
  }
  AxisState state(StandAxis axis) {
    const auto s = stand().read_state(axis);
    EXPECT_TRUE(s) << s.status().message;
    return s ? s.value() : AxisState{};
  }

  Backend backend_;
};

using StandBackends = ::testing::Types<SimStandBackend, ModbusStandBackend>;
class StandBackendNames {
 public:
  template <class T>
  static std::string GetName(int) {
    return std::is_same_v<T, SimStandBackend> ? "sim" : "modbus";
  }
};
TYPED_TEST_SUITE(StandContract, StandBackends, StandBackendNames);

const InPositionRule kRule{0.001, 0.05, 30.0, 0.01};

TYPED_TEST(StandContract, AnUnconfiguredStandRefusesEverythingButConfigure) {
  Stand& s = this->stand();
  EXPECT_EQ(s.lifecycle(), Lifecycle::unconfigured);
  EXPECT_EQ(s.read_state(StandAxis::outer).status().kind, ErrorKind::not_allowed);
  EXPECT_EQ(s.activate().kind, ErrorKind::not_allowed);
  EXPECT_EQ(s.enable(StandAxis::outer).kind, ErrorKind::not_allowed);
  EXPECT_EQ(s.move_to(StandAxis::outer, 10).kind, ErrorKind::not_allowed);
  EXPECT_EQ(s.stop(StandAxis::outer).kind, ErrorKind::not_allowed);
  const Status recover = s.recover();
  EXPECT_EQ(recover.kind, ErrorKind::not_allowed);
  EXPECT_NE(recover.message.find("not in error"), std::string::npos) << recover.message;
  EXPECT_TRUE(s.cleanup()) << "nothing to clean up";
  EXPECT_EQ(s.lifecycle(), Lifecycle::unconfigured);
}

TYPED_TEST(StandContract, TransitionsFollowTheOneTable) {
  Stand& s = this->stand();
  ASSERT_TRUE(s.configure());
  EXPECT_EQ(s.lifecycle(), Lifecycle::inactive);
  EXPECT_TRUE(s.configure()) << "configuring a configured stand has nothing to do";
  EXPECT_EQ(s.recover().kind, ErrorKind::not_allowed) << "inactive is not an error";
  EXPECT_TRUE(s.deactivate()) << "deactivating an inactive stand has nothing to do";
  ASSERT_TRUE(s.activate());
  EXPECT_EQ(s.lifecycle(), Lifecycle::active);
  EXPECT_TRUE(s.activate());
  EXPECT_TRUE(s.configure());
  EXPECT_EQ(s.lifecycle(), Lifecycle::active);
  EXPECT_EQ(s.recover().kind, ErrorKind::not_allowed) << "active is not an error";
  const Status cleanup_active = s.cleanup();
  EXPECT_EQ(cleanup_active.kind, ErrorKind::not_allowed);
  EXPECT_NE(cleanup_active.message.find("deactivate"), std::string::npos) << cleanup_active.message;
  ASSERT_TRUE(s.deactivate());
  EXPECT_EQ(s.lifecycle(), Lifecycle::inactive);
  ASSERT_TRUE(s.cleanup());
  EXPECT_EQ(s.lifecycle(), Lifecycle::unconfigured);
  ASSERT_TRUE(s.configure()) << "a cleaned-up stand configures again";
  EXPECT_EQ(s.lifecycle(), Lifecycle::inactive);
}

TYPED_TEST(StandContract, MotionIsRefusedUnlessActiveEnabledAndHomed) {
  Stand& s = this->stand();
  ASSERT_TRUE(s.configure());
  for (StandAxis a : kAxes) {
    EXPECT_EQ(s.enable(a).kind, ErrorKind::not_allowed) << "inactive";
    EXPECT_EQ(s.home(a).kind, ErrorKind::not_allowed) << "inactive";
    EXPECT_EQ(s.move_to(a, 10).kind, ErrorKind::not_allowed) << "inactive";
  }
  ASSERT_TRUE(s.activate());
  const Status disabled = s.move_to(StandAxis::inner, 10);
  EXPECT_EQ(disabled.kind, ErrorKind::not_allowed);
  EXPECT_NE(disabled.message.find("disabled"), std::string::npos) << disabled.message;
  EXPECT_EQ(s.home(StandAxis::inner).kind, ErrorKind::not_allowed)
      << "a disabled axis does not home";
  ASSERT_TRUE(s.enable(StandAxis::inner));
  EXPECT_TRUE(this->state(StandAxis::inner).enabled);
  const Status not_homed = s.move_to(StandAxis::inner, 10);
  EXPECT_EQ(not_homed.kind, ErrorKind::not_allowed);
  EXPECT_NE(not_homed.message.find("not homed"), std::string::npos) << not_homed.message;
  ASSERT_TRUE(s.home(StandAxis::inner));
  ASSERT_TRUE(wait_homed(s, StandAxis::inner, 30.0, 0.01));
  EXPECT_TRUE(s.move_to(StandAxis::inner, 10));
}

TYPED_TEST(StandContract, BothAxesReachTheirTargetsByTheOneInPositionRule) {
  this->make_ready_to_move();
  Stand& s = this->stand();
  ASSERT_TRUE(s.move_to(StandAxis::outer, 40));
  ASSERT_TRUE(s.move_to(StandAxis::inner, 270));  // ±180° axis: 270° is −90°
  const AxisTarget targets[] = {{StandAxis::outer, 40}, {StandAxis::inner, -90}};
  const auto reached = wait_in_position(s, targets, kRule);
  ASSERT_TRUE(reached) << reached.status().message;
  EXPECT_NEAR(reached.value()[0], 40, kRule.window_deg);
  EXPECT_NEAR(reached.value()[1], -90, kRule.window_deg);
  for (StandAxis a : kAxes) EXPECT_EQ(this->state(a).mode, AxisMode::in_position);
}

TYPED_TEST(StandContract, AWaitTimesOutSayingWhereTheAxisIsAndWhatItDoes) {
  this->make_ready_to_move();
  Stand& s = this->stand();
  ASSERT_TRUE(s.move_to(StandAxis::outer, 170));
  InPositionRule impatient = kRule;
  impatient.timeout_s = 0.02;  // far shorter than the move
  const auto reached = wait_in_position(s, StandAxis::outer, 170, impatient);
  ASSERT_FALSE(reached);
  EXPECT_EQ(reached.status().kind, ErrorKind::timeout);
  const std::string& m = reached.status().message;
  EXPECT_NE(m.find("axis 1 (outer) did not reach 170.0000° within 0.02 s: at "), std::string::npos)
      << m;
  EXPECT_NE(m.find(", moving"), std::string::npos) << m;
  ASSERT_TRUE(s.stop(StandAxis::outer));
}

TYPED_TEST(StandContract, AStoppedAxisStaysEnabledShortOfItsTarget) {
  this->make_ready_to_move();
  Stand& s = this->stand();
  ASSERT_TRUE(s.move_to(StandAxis::outer, 170));
  sleep_s(0.05);
  ASSERT_TRUE(s.stop(StandAxis::outer));
  sleep_s(0.3);  // any deceleration is over
  const AxisState stopped = this->state(StandAxis::outer);
  EXPECT_TRUE(stopped.enabled);
  EXPECT_NE(stopped.mode, AxisMode::moving);
  EXPECT_LT(stopped.angle_deg, 160.0);
  sleep_s(0.1);
  EXPECT_NEAR(this->state(StandAxis::outer).angle_deg, stopped.angle_deg, 0.002)
      << "it stays stopped";
}

TYPED_TEST(StandContract, AnEmergencyStopLatchesUntilRecoverInEveryBackend) {
  this->make_ready_to_move();
  Stand& s = this->stand();
  ASSERT_TRUE(s.move_to(StandAxis::outer, 120));
  ASSERT_TRUE(s.emergency_stop());
  EXPECT_EQ(s.lifecycle(), Lifecycle::error);
  for (StandAxis a : kAxes) {
    const AxisState st = this->state(a);  // an e-stopped stand can still be read
    EXPECT_TRUE(st.estop);
    EXPECT_FALSE(st.enabled);
  }
  EXPECT_EQ(s.move_to(StandAxis::outer, 0).kind, ErrorKind::estop);
  EXPECT_EQ(s.enable(StandAxis::outer).kind, ErrorKind::estop);
  EXPECT_EQ(s.activate().kind, ErrorKind::estop);
  EXPECT_EQ(s.configure().kind, ErrorKind::estop);
  EXPECT_TRUE(s.disable(StandAxis::outer)) << "taking power away is always allowed";
  EXPECT_TRUE(s.stop(StandAxis::outer));
  ASSERT_TRUE(s.recover());
  EXPECT_EQ(s.lifecycle(), Lifecycle::inactive);
  EXPECT_FALSE(this->state(StandAxis::outer).estop);
  ASSERT_TRUE(s.activate());
  ASSERT_TRUE(s.enable(StandAxis::outer));
}

// The latch is the controller's: a driver that connects after the e-stop finds it at
// configure() and cannot move until it has recovered.
TYPED_TEST(StandContract, ALatchedEmergencyStopIsFoundAtConfigure) {
  Stand& first = this->stand();
  ASSERT_TRUE(first.emergency_stop());
  EXPECT_EQ(first.lifecycle(), Lifecycle::unconfigured) << "an unconfigured stand stays so";
  ASSERT_TRUE(first.configure());
  EXPECT_EQ(first.lifecycle(), Lifecycle::error);
  EXPECT_EQ(first.activate().kind, ErrorKind::estop);
  ASSERT_TRUE(first.recover());
  EXPECT_EQ(first.lifecycle(), Lifecycle::inactive);
  ASSERT_TRUE(first.activate());
}

TYPED_TEST(StandContract, AnEmergencyStopDuringAWaitEndsItAtOnce) {
  this->make_ready_to_move();
  Stand& s = this->stand();
  ASSERT_TRUE(s.move_to(StandAxis::outer, 170));
  // The pause hook is where the daemon serves requests while it waits: an operator's
  // e-stop arrives there.
  const WaitClock steady = steady_wait_clock();
  int pauses = 0;
  const WaitClock with_estop{steady.now_s, [&](double seconds) {
                               if (++pauses == 2) {
                                 ASSERT_TRUE(s.emergency_stop());
                               }
                               steady.pause_s(seconds);
                             }};
  const auto reached = wait_in_position(s, StandAxis::outer, 170, kRule, with_estop);
  ASSERT_FALSE(reached);
  EXPECT_EQ(reached.status().kind, ErrorKind::estop) << reached.status().message;
  EXPECT_NE(reached.status().message.find("emergency stop while moving to 170.0000°"),
            std::string::npos)
      << reached.status().message;
}

// The controller halts an axis whose driver stopped beating; the next driver's wait must
// not take the halted axis for a slow one.
TYPED_TEST(StandContract, AHeartbeatStopEndsTheNextWaitAtOnce) {
  if constexpr (!TypeParam::kHasLink) {
    GTEST_SKIP() << "the simulated stand has no link and so no heartbeat watchdog";
  } else {
    this->make_ready_to_move();
    ASSERT_TRUE(this->stand().move_to(StandAxis::outer, 170));
    sleep_s(0.1);
    this->backend_.reconnect();  // the driver vanishes without a word
    sleep_s(2.0);                // watchdog 1 s, then a controlled stop
    Stand& s = this->stand();
    ASSERT_TRUE(s.configure());
    ASSERT_TRUE(s.activate());
    const auto reached = wait_in_position(s, StandAxis::outer, 170, kRule);
    ASSERT_FALSE(reached);
    EXPECT_EQ(reached.status().kind, ErrorKind::link) << reached.status().message;
    EXPECT_NE(reached.status().message.find("heartbeat lost"), std::string::npos)
        << reached.status().message;
  }
}

}  // namespace
}  // namespace standcal::drivers
