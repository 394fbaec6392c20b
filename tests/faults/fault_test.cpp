// Each fault of issue 7 once on the real daemon and emulators (fault_cases.hpp), and a
// few seeded SIGKILL / power-loss points; bench/faults runs many more seeds. A trial
// passes only when all four promises hold: the stand ends stopped, the run's state is
// truthful (in run.status and in run.json), every position recorded before the fault is
// byte-for-byte intact, and resume completes the run with every position exactly once.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>

#include "tests/faults/fault_cases.hpp"

using namespace standcal::faults;

namespace {

RigOptions rig_options() {
  RigOptions o;
  o.daemon_path = STANDCALD_PATH;
  o.stand_emu_path = STANDCAL_STAND_EMU_PATH;
  o.can_emu_path = STANDCAL_CAN_EMU_PATH;
  return o;
}

void expect_survives(const std::string& name, unsigned seed = 1) {
  const FaultCase c = find_case(name);
  if (c.rtu && !std::filesystem::exists("/usr/bin/socat")) GTEST_SKIP() << "socat is not installed";
  RigOptions o = rig_options();
  // FAULTS_KEEP_DIR=/tmp/x keeps each trial's logs, config and recording there.
  if (const char* keep = std::getenv("FAULTS_KEEP_DIR"))
    o.work_dir = std::string(keep) + "/" + name + "-" + std::to_string(seed);
  const Trial t = run_trial(o, c, seed);
  EXPECT_TRUE(t.survived) << name << " seed " << seed << ": " << t.failure;
  EXPECT_EQ(t.positions_lost, 0);
  EXPECT_EQ(t.state_after_fault, c.expect) << t.reason;
  std::printf("%s (seed %u): %s%s%s\n", name.c_str(), seed, t.state_after_fault.c_str(),
              t.reason.empty() ? "" : ": ", t.reason.c_str());
}

}  // namespace

TEST(Faults, ModbusTimeoutFaultsTheRunAndResumeCompletesIt) { expect_survives("modbus_timeout"); }
TEST(Faults, ModbusTimeoutDuringAMoveStopsTheAxesOnceTheLinkIsBack) {
  expect_survives("modbus_timeout_mid_move");
}
TEST(Faults, ModbusExceptionFaultsTheRunAndResumeCompletesIt) {
  expect_survives("modbus_exception");
}
TEST(Faults, OneDroppedTcpConnectionIsRetriedAndTheRunCompletes) {
  expect_survives("tcp_drop_once");
}
TEST(Faults, APersistentlyDroppedConnectionFaultsTheRunAndResumeCompletesIt) {
  expect_survives("tcp_drop_persistent");
}
TEST(Faults, TwoRtuCrcErrorsAreRetriedAndTheRunCompletes) { expect_survives("rtu_crc_once"); }
TEST(Faults, PersistentRtuCrcErrorsFaultTheRunAndResumeCompletesIt) {
  expect_survives("rtu_crc_persistent");
}
TEST(Faults, StuckAxisFaultsTheRunAndResumeCompletesIt) { expect_survives("stuck_axis"); }
TEST(Faults, SlowAxisFaultsTheRunAndResumeCompletesIt) { expect_survives("slow_axis"); }
TEST(Faults, OvershootIsNeverRecordedAsInPosition) { expect_survives("overshoot"); }
TEST(Faults, CanSilenceFaultsTheRunAndResumeCompletesIt) { expect_survives("can_silence"); }
TEST(Faults, CanBusOffFaultsTheRunAndResumeCompletesIt) { expect_survives("can_bus_off"); }
TEST(Faults, MissingCanFramesFaultTheRunAfterReMeasuring) { expect_survives("can_missing_frames"); }
TEST(Faults, DuplicatedCanFramesAreIgnored) { expect_survives("can_duplicate_frames"); }
TEST(Faults, DiskFullFaultsTheRunAndResumeCompletesIt) { expect_survives("disk_full"); }
TEST(Faults, SigkillAtSeededPointsThenResume) {
  for (unsigned seed : {11u, 12u}) expect_survives("sigkill", seed);
}
TEST(Faults, PowerLossCutsTheRecordingAtASeededByteThenResume) {
  for (unsigned seed : {21u, 22u}) expect_survives("power_loss", seed);
}
