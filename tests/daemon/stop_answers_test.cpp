// run.pause, run.resume, run.abort and stand.stop answer once what they report is true:
// a client that reads run.status or status right after the answer sees the new state and
// a stopped stand (as run.start and run.resume already did).
#include <gtest/gtest.h>

#include "daemon_process.hpp"

using namespace standcal;
using namespace std::chrono_literals;
using nlohmann::json;
using protocol::Client;
using test::DaemonProcess;
using test::finished;
using test::socket_of;
using test::TempDir;
using test::wait_run;

namespace {

// The axes as `status` shows them; a failure names the axis still moving.
void expect_axes_stopped(Client& c, const std::string& after) {
  const json axes = c.call("status")["stand"]["axes"];
  ASSERT_EQ(axes.size(), 2u) << axes.dump();
  for (const json& axis : axes) {
    const std::string mode = axis.value("mode", "");
    EXPECT_TRUE(mode != "moving" && mode != "homing") << "after " << after << ": " << axis.dump();
  }
}

std::string start_long_run(Client& c, const std::string& serial) {
  const std::string id = c.call(
      "run.start",
      {{"program", "paper9"}, {"unit_serial", serial}, {"dwell_s", 30}, {"settle_s", 1}})["run_id"];
  wait_run(c, id, [](const json& s) { return s.value("positions_done", 0) >= 1; });
  return id;
}

}  // namespace

TEST(DaemonStopAnswers, PauseAndResumeAnswerOnceTheRunIsInThatState) {
  TempDir dir;
  auto daemon = DaemonProcess::sim(dir.path(), 200);
  Client c(socket_of(dir));
  const std::string run_id = start_long_run(c, "AU-P");
  for (int round = 0; round < 3; ++round) {
    EXPECT_EQ(c.call("run.pause", {{"run_id", run_id}})["state"], "paused");
    EXPECT_EQ(test::run_state_of(c, run_id), "paused") << "round " << round;
    EXPECT_EQ(c.call("status")["run"]["state"], "paused") << "round " << round;
    expect_axes_stopped(c, "run.pause");
    c.call("run.resume", {{"run_id", run_id}});
    EXPECT_EQ(test::run_state_of(c, run_id), "running") << "round " << round;
  }
  c.call("run.abort", {{"run_id", run_id}});
}

TEST(DaemonStopAnswers, AbortAnswersOnceTheRunIsAborted) {
  TempDir dir;
  auto daemon = DaemonProcess::sim(dir.path(), 200);
  Client c(socket_of(dir));
  const std::string run_id = start_long_run(c, "AU-A");
  EXPECT_EQ(c.call("run.abort", {{"run_id", run_id}})["state"], "aborted");
  EXPECT_EQ(test::run_state_of(c, run_id), "aborted");
  EXPECT_TRUE(c.call("status")["run"].is_null());
  expect_axes_stopped(c, "run.abort");
}

TEST(DaemonStopAnswers, StandStopDuringARunAnswersOnceTheRunIsPaused) {
  TempDir dir;
  auto daemon = DaemonProcess::sim(dir.path(), 200);
  Client c(socket_of(dir));
  const std::string run_id = start_long_run(c, "AU-S");
  EXPECT_EQ(c.call("stand.stop")["stopped"], true);
  EXPECT_EQ(test::run_state_of(c, run_id), "paused");
  expect_axes_stopped(c, "stand.stop");
  c.call("run.abort", {{"run_id", run_id}});
}

TEST(DaemonStopAnswers, StandStopAnswersOnceTheAxesHaveStopped) {
  TempDir dir;
  auto daemon = DaemonProcess::sim(dir.path(), 1);  // real time: a long move takes seconds
  Client c(socket_of(dir));
  c.call("stand.enable");
  c.call("stand.home", json::object(), 60s);
  EXPECT_EQ(c.call("stand.move",
                   {{"alpha1_deg", 170}, {"alpha2_deg", -170}, {"wait", false}})["accepted"],
            true);
  EXPECT_EQ(c.call("stand.stop")["stopped"], true);
  expect_axes_stopped(c, "stand.stop");
}

TEST(DaemonStopAnswers, EstopDuringARunAnswersOnceTheRunHasFaulted) {
  TempDir dir;
  auto daemon = DaemonProcess::sim(dir.path(), 200);
  Client c(socket_of(dir));
  const std::string run_id = start_long_run(c, "AU-E");
  EXPECT_EQ(c.call("estop")["estop"], true);
  EXPECT_EQ(test::run_state_of(c, run_id), "faulted");
  expect_axes_stopped(c, "estop");
}
