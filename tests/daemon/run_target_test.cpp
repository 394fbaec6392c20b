// Run-targeted commands (run.pause, run.abort, run.resume, operator.confirm) that name a
// run act on that run only: naming a run that is not the active one is an error, and
// nothing changes (docs/protocol.md, "Run-targeted methods").
#include <gtest/gtest.h>

#include "daemon_process.hpp"

using namespace standcal;
using namespace std::chrono_literals;
using nlohmann::json;
using protocol::Client;
using protocol::RpcError;
using test::DaemonProcess;
using test::finished;
using test::socket_of;
using test::TempDir;
using test::wait_run;

namespace {

int error_code_of(Client& c, const std::string& method, const json& params) {
  return test::refusal_of(c, method, params).code();
}

// A run left `interrupted` by a SIGTERM of the daemon that ran it (resumable).
std::string interrupted_run(const TempDir& dir) {
  auto daemon = DaemonProcess::sim(dir.path(), 100);
  Client c(socket_of(dir));
  const std::string id = c.call(
      "run.start", {{"program", "paper9"}, {"unit_serial", "AU-OLD"}, {"dwell_s", 600}})["run_id"];
  daemon->kill_now(SIGTERM);
  return id;
}

}  // namespace

TEST(DaemonRunTarget, ConfirmNamingAnotherRunConfirmsNothing) {
  TempDir dir;
  auto daemon = DaemonProcess::sim(dir.path(), 500);
  Client c(socket_of(dir));
  const std::string run_id = c.call("run.start", {{"program", "classic24"},
                                                  {"unit_serial", "AU-7"},
                                                  {"dwell_s", 10},
                                                  {"settle_s", 1}})["run_id"];
  wait_run(c, run_id,
           [](const json& s) { return s["state"] == "waiting_operator" || finished(s); });
  ASSERT_EQ(test::run_state_of(c, run_id), "waiting_operator");

  EXPECT_EQ(error_code_of(c, "operator.confirm", {{"run_id", "nope"}}), -32006);
  EXPECT_EQ(test::run_state_of(c, run_id), "waiting_operator");  // the re-mount was not confirmed

  EXPECT_EQ(c.call("operator.confirm", {{"run_id", run_id}})["confirmed"], true);
  c.call("run.abort", {{"run_id", run_id}});
}

TEST(DaemonRunTarget, PauseAbortAndResumeNamingAnOldRunLeaveTheActiveRunAlone) {
  TempDir dir;
  const std::string old_id = interrupted_run(dir);
  auto daemon = DaemonProcess::sim(dir.path(), 100);
  Client c(socket_of(dir));
  ASSERT_EQ(test::run_state_of(c, old_id), "interrupted");
  const std::string active = c.call(
      "run.start", {{"program", "paper9"}, {"unit_serial", "AU-NEW"}, {"dwell_s", 600}})["run_id"];

  EXPECT_EQ(error_code_of(c, "run.abort", {{"run_id", old_id}}), -32007);
  EXPECT_EQ(error_code_of(c, "run.pause", {{"run_id", old_id}}), -32007);
  EXPECT_EQ(error_code_of(c, "run.pause", {{"run_id", "nope"}}), -32006);
  EXPECT_EQ(test::run_state_of(c, active), "running");

  c.call("run.pause", {{"run_id", active}});
  ASSERT_EQ(wait_run(c, active, [](const json& s) { return s["state"] != "running"; })["state"],
            "paused");
  // Another run cannot be resumed while this one holds the stand, and this one stays paused.
  EXPECT_EQ(error_code_of(c, "run.resume", {{"run_id", old_id}}), -32001);
  EXPECT_EQ(error_code_of(c, "run.abort", {{"run_id", old_id}}), -32007);
  EXPECT_EQ(test::run_state_of(c, active), "paused");
  EXPECT_EQ(test::run_state_of(c, old_id), "interrupted");

  c.call("run.resume", {{"run_id", active}});
  EXPECT_EQ(wait_run(c, active, [](const json& s) { return s["state"] != "paused"; })["state"],
            "running");
  c.call("run.abort", {{"run_id", active}});
  EXPECT_EQ(wait_run(c, active, finished)["state"], "aborted");
  EXPECT_EQ(test::run_state_of(c, old_id), "interrupted");  // still resumable
}
