// `standcal stand ...` bring-up commands against the emulator process: what an engineer
// types and reads.
#include <gtest/gtest.h>

#include <cstdio>
#include <string>

#include <nlohmann/json.hpp>

#include "emulator_process.hpp"
#include "tests/support/command.hpp"
#include "tests/support/temp_dir.hpp"

namespace standcal::test {
namespace {

using CliRun = test::CommandOutcome;

CliRun standcal_stand(const std::string& arguments) {
  return test::standcal_cli("stand " + arguments);
}

TEST(StandCli, EnableMoveAndStatusAgainstTheEmulator) {
  EmulatorProcess emulator("tcp://127.0.0.1:0", {"--time-scale", "10"});
  // A watchdog of 10 s, not the default 1 s: this test is about the commands, and under the
  // sanitizers beside other tests on 2 cores the CLI's I/O thread was once starved for a
  // second while homing, so the emulator stopped the axes ("heartbeat lost"). The watchdog
  // itself is tested in test_modbus_tcp.cpp (StandOverTcp) and by the fault tests.
  const TempDir dir;
  dir.write("stand.json", R"({"timing": {"heartbeat_timeout_s": 10}})");
  const std::string url = "--url " + emulator.url() + " --config " + dir.file("stand.json");
  const CliRun enabled = standcal_stand(url + " enable");
  ASSERT_EQ(enabled.exit_code, 0) << enabled.output;
  const CliRun unreferenced = standcal_stand(url + " --timeout-s 20 move 270 -45.5");
  EXPECT_EQ(unreferenced.exit_code, 1) << "an axis that has not found its reference does not move";
  EXPECT_NE(
      unreferenced.output.find("outer axis is not homed: home it before moving the outer axis"),
      std::string::npos)
      << unreferenced.output;
  const CliRun homed = standcal_stand(url + " --timeout-s 20 home");
  ASSERT_EQ(homed.exit_code, 0) << homed.output;
  const CliRun moved = standcal_stand(url + " --timeout-s 20 move 270 -45.5");
  ASSERT_EQ(moved.exit_code, 0) << moved.output;
  double outer_deg = 0, inner_deg = 0;
  ASSERT_EQ(std::sscanf(moved.output.c_str(), "outer %lf° inner %lf°", &outer_deg, &inner_deg), 2)
      << moved.output;
  EXPECT_NEAR(outer_deg, -90.0, 0.001);  // the angles reached, read with encoder noise
  EXPECT_NEAR(inner_deg, -45.5, 0.001);
  const CliRun status = standcal_stand(url + " status --json");
  ASSERT_EQ(status.exit_code, 0) << status.output;
  const auto json = nlohmann::json::parse(status.output);
  EXPECT_NEAR(json["axes"]["outer"]["angle_deg"].get<double>(), -90.0, 0.001);
  EXPECT_EQ(json["axes"]["inner"]["mode"], "in_position");
  EXPECT_EQ(json["axes"]["inner"]["enabled"], true);
}

// A config whose retries outlast the controller's watchdog is used, and said first.
TEST(StandCli, ATimingWhoseRetriesOutlastTheWatchdogIsSaid) {
  EmulatorProcess emulator("tcp://127.0.0.1:0", {});
  const TempDir dir;
  dir.write("stand.json", R"({"timing": {"heartbeat_timeout_s": 0.5}})");
  const CliRun status =
      standcal_stand("--url " + emulator.url() + " --config " + dir.file("stand.json") + " status");
  EXPECT_EQ(status.exit_code, 0) << status.output;
  EXPECT_EQ(status.output.rfind("warning: " + dir.file("stand.json") +
                                    ": timing: a request retried 3 times at timeout_s 0.3 s",
                                0),
            0u)
      << status.output;
  EXPECT_NE(status.output.find("outer: "), std::string::npos) << status.output;
}

TEST(StandCli, NoServerExitsNonZeroWithOneLine) {
  std::string url;
  {
    EmulatorProcess gone("tcp://127.0.0.1:0", {});
    url = gone.url();
  }
  const CliRun run = standcal_stand("--url " + url + " status");
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_EQ(run.output.rfind("standcal: no reply from " + url + " unit 1 after 3 tries", 0), 0u)
      << run.output;
  EXPECT_EQ(run.output.find('\n'), run.output.size() - 1) << "one line: " << run.output;
}

TEST(StandCli, EstopThenResetThenEnable) {
  EmulatorProcess emulator("tcp://127.0.0.1:0", {});
  const std::string url = "--url " + emulator.url();
  ASSERT_EQ(standcal_stand(url + " estop").exit_code, 0);
  const CliRun refused = standcal_stand(url + " enable");
  EXPECT_EQ(refused.exit_code, 1);
  EXPECT_NE(refused.output.find("recover first"), std::string::npos) << refused.output;
  ASSERT_EQ(standcal_stand(url + " reset").exit_code, 0);
  const CliRun enabled = standcal_stand(url + " enable");
  EXPECT_EQ(enabled.exit_code, 0) << enabled.output;
}

}  // namespace
}  // namespace standcal::test
