// `run.diagnose` through the real standcald process on the simulated backend: errors for
// runs that cannot be diagnosed, the diagnosis of finished runs (same shape as
// `standcal diagnose --json`), the socket thread staying responsive while a diagnosis is
// computed, and `standcal run diagnose --report / --run-proposed`.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <set>
#include <sstream>

#include "calib/diagnosis/diagnosis.hpp"
#include "calib/recording.hpp"
#include "daemon_process.hpp"
#include "tests/support/command.hpp"

using namespace standcal;
using namespace std::chrono_literals;
using nlohmann::json;
using protocol::Client;
using protocol::RpcError;
using test::DaemonProcess;
using test::socket_of;
using test::TempDir;

namespace {

std::pair<int, std::string> error_of(const std::function<void()>& call) {
  try {
    call();
  } catch (const RpcError& e) {
    return {e.code(), e.what()};
  }
  return {0, ""};
}

// Sixteen distinct poses on one mount (docs/diagnosis.md's diagnostic programme, one pass):
// enough redundancy for the full-vector baseline and the catalog.
json diagnostic_positions() {
  json p = json::array();
  for (double a1 : {0.0, 60.0, 120.0, 180.0, 240.0, 300.0})
    p.push_back({{"alpha1_deg", a1}, {"alpha2_deg", 0.0}});
  for (double a2 : {45.0, 90.0, 135.0, 225.0, 270.0, 315.0})
    p.push_back({{"alpha1_deg", 0.0}, {"alpha2_deg", a2}});
  for (auto [a1, a2] : {std::pair{45.0, 90.0}, {45.0, 270.0}, {30.0, 60.0}, {330.0, 120.0}})
    p.push_back({{"alpha1_deg", a1}, {"alpha2_deg", a2}});
  return p;
}

std::string run_to_end(Client& c, const json& program, const std::string& unit, double dwell_s,
                       const std::string& unit_type = "") {
  json params{{"program", program}, {"unit_serial", unit}, {"dwell_s", dwell_s}, {"settle_s", 1}};
  if (!unit_type.empty()) params["unit_type"] = unit_type;
  const std::string id = c.call("run.start", params)["run_id"];
  const json s = test::wait_run(c, id, test::finished, 120s);
  EXPECT_EQ(s["state"], "done") << s.dump();
  return id;
}

std::string run_cli(const std::string& args) {
  const test::CommandOutcome r = test::standcal_cli(args);
  if (r.exit_code != 0) throw std::runtime_error("`standcal " + args + "` failed:\n" + r.output);
  return r.output;
}

// Whether the stand reaches `deg` on an axis limited to [min_deg, max_deg] (any turn).
bool reachable(double deg, double min_deg, double max_deg) {
  for (int turn = -2; turn <= 2; ++turn) {
    const double a = deg + 360.0 * turn;
    if (a >= min_deg - 1e-9 && a <= max_deg + 1e-9) return true;
  }
  return false;
}

const std::set<std::string> kVerdicts{"consistent", "explained", "unexplained",
                                      "insufficient_redundancy", "ambiguous"};

}  // namespace

TEST(DaemonDiagnose, RunsThatCannotBeDiagnosedAreClearErrors) {
  TempDir dir;
  auto daemon = DaemonProcess::sim(dir.path(), 300);
  Client c(socket_of(dir));
  const auto [code, message] = error_of([&] {
    c.call("run.diagnose", {{"run_id", "20990101T000000Z-NOPE"}});
  });
  EXPECT_EQ(code, -32006);
  EXPECT_NE(message.find("20990101T000000Z-NOPE"), std::string::npos) << message;
  EXPECT_EQ(error_of([&] { c.call("run.diagnose"); }).first, -32602);  // run_id is required
  EXPECT_EQ(error_of([&] {
              c.call("run.diagnose", {{"run_id", "x"}, {"reprot", true}});
            }).first,
            -32602);
  EXPECT_EQ(error_of([&] { c.call("run.diagnose", {{"run_id", 7}}); }).first, -32602);
  // A run in progress: its recording is still growing.
  const std::string id = c.call(
      "run.start", {{"program", "paper9"}, {"unit_serial", "AU-D0"}, {"dwell_s", 600}})["run_id"];
  const auto [busy_code, busy_message] = error_of([&] {
    c.call("run.diagnose", {{"run_id", id}});
  });
  EXPECT_EQ(busy_code, -32007);
  EXPECT_NE(busy_message.find(id), std::string::npos) << busy_message;
  c.call("run.abort", {{"run_id", id}});
}

TEST(DaemonDiagnose, FinishedRunHasAVerdictInTheShapeOfTheCli) {
  TempDir dir;
  auto daemon = DaemonProcess::sim(dir.path(), 300);
  Client c(socket_of(dir));
  const std::string id = run_to_end(c, diagnostic_positions(), "AU-D1", 10);
  const json d = c.call("run.diagnose", {{"run_id", id}}, 300s);
  ASSERT_TRUE(d["verdict"].is_string()) << d.dump();
  EXPECT_TRUE(kVerdicts.count(d["verdict"].get<std::string>())) << d["verdict"];
  EXPECT_EQ(d["method"], "full");  // 16 distinct positions: the full-vector baseline has redundancy
  EXPECT_TRUE(d["baseline"]["chi2_dof"].is_number());
  EXPECT_TRUE(d["final"]["parameters"].is_object());
  EXPECT_TRUE(d["findings"].is_array());
  EXPECT_EQ(d["run_id"], id);
  EXPECT_EQ(d["unit_serial"], "AU-D1");
  EXPECT_FALSE(d.contains("report_html"));
  // Kept with the run.
  std::ifstream saved(d["saved_path"].get<std::string>());
  ASSERT_TRUE(saved.good()) << d["saved_path"];
  const json kept = json::parse(saved);
  EXPECT_EQ(kept["verdict"], d["verdict"]);
  EXPECT_EQ(kept["findings"], d["findings"]);
  // The same answer as the library on the stored recording (what `standcal diagnose --json`
  // prints).
  const json local = diagnose_to_json(diagnose_recording(read_recording(d["recording_path"])));
  EXPECT_EQ(d["verdict"], local["verdict"]);
  EXPECT_EQ(d["baseline"], local["baseline"]);
  EXPECT_EQ(d["findings"], local["findings"]);
  // With the report: a self-contained page with the figures.
  const json r = c.call("run.diagnose", {{"run_id", id}, {"report", true}}, 300s);
  ASSERT_TRUE(r["report_html"].is_string()) << r.value("report_note", "");
  EXPECT_NE(r["report_html"].get<std::string>().find("<svg"), std::string::npos);
}

TEST(DaemonDiagnose, TheSocketAnswersWhileADiagnosisIsComputed) {
  TempDir dir;
  auto daemon = DaemonProcess::sim(dir.path(), 300);
  Client c(socket_of(dir));
  const std::string id = run_to_end(c, "paper9", "AU-D2", 30);
  // Both requests in one write: `status` is answered on the socket thread at once, the
  // diagnosis when the worker is done, so the status answer comes first.
  c.send_raw(
      json{
          {"jsonrpc", "2.0"}, {"id", 101}, {"method", "run.diagnose"}, {"params", {{"run_id", id}}}}
          .dump() +
      "\n" + json{{"jsonrpc", "2.0"}, {"id", 102}, {"method", "status"}}.dump() + "\n");
  std::vector<json> answers;
  const auto deadline = std::chrono::steady_clock::now() + 300s;
  while (answers.size() < 2 && std::chrono::steady_clock::now() < deadline) {
    auto m = c.next_message(1s);
    if (m && m->contains("id")) answers.push_back(*m);
  }
  ASSERT_EQ(answers.size(), 2u);
  EXPECT_EQ(answers[0]["id"], 102);
  EXPECT_EQ(answers[1]["id"], 101);
  EXPECT_EQ(answers[1]["result"]["verdict"], "insufficient_redundancy") << answers[1].dump();
}

TEST(DaemonDiagnose, CliWritesTheReportAndRunsTheProposedPositions) {
  TempDir dir;
  auto daemon = DaemonProcess::sim(dir.path(), 300);
  Client c(socket_of(dir));
  // paper9 has no redundancy: the diagnosis proposes positions to add.
  const std::string id = run_to_end(c, "paper9", "AU-D3", 20, "QA-7");
  const std::string report = dir.path() + "/report.html";
  const std::string text = run_cli("run diagnose " + id + " --json --report " + report +
                                   " --run-proposed --dwell-s 5 --socket " + socket_of(dir));
  const json d = json::parse(text.substr(text.find('{')));
  EXPECT_EQ(d["verdict"], "insufficient_redundancy");
  ASSERT_FALSE(d["proposed_positions"].empty());
  std::ifstream in(report);
  std::stringstream html;
  html << in.rdbuf();
  EXPECT_NE(html.str().find("<svg"), std::string::npos);
  EXPECT_NE(html.str().find("Proposed positions"), std::string::npos);
  // The follow-up run: the proposed positions, same unit, named after the run it follows.
  const std::string follow = d["follow_up_run"]["run_id"];
  EXPECT_EQ(d["follow_up_run"]["positions"], d["proposed_positions"].size());
  const json s = test::wait_run(c, follow, test::finished, 120s);
  EXPECT_EQ(s["state"], "done") << s.dump();
  EXPECT_EQ(s["unit_serial"], "AU-D3");
  EXPECT_EQ(s["unit_type"], "QA-7") << "the follow-up inherits the unit type";
  EXPECT_EQ(s["program"], "follow-up of " + id);
  const Recording rec = read_recording(s["recording_path"]);
  ASSERT_FALSE(rec.samples.empty());
  // (the stand may write 270 deg as -90 deg: compare modulo a turn)
  EXPECT_NEAR(std::remainder(rec.samples.front().alpha1_cmd_deg -
                                 d["proposed_positions"][0]["alpha1_deg"].get<double>(),
                             360.0),
              0, 1e-9);
  EXPECT_NEAR(std::remainder(rec.samples.front().alpha2_cmd_deg -
                                 d["proposed_positions"][0]["alpha2_deg"].get<double>(),
                             360.0),
              0, 1e-9);
}

// A stand whose outer axis only turns -100..100 deg (config stand.outer): the positions the
// diagnosis proposes are ones it can reach, and the follow-up run could be started.
TEST(DaemonDiagnose, ProposedPositionsLieInsideTheConfiguredStandRanges) {
  TempDir dir;
  const std::string config = dir.path() + "/standcald.json";
  std::ofstream(config) << json{{"stand", {{"outer", {{"min_deg", -100}, {"max_deg", 100}}}}}}.dump(
      2);
  auto daemon = DaemonProcess::sim(dir.path(), 300, {"--config", config});
  Client c(socket_of(dir));
  json program = json::array();
  for (auto [a1, a2] : {std::pair{0.0, 0.0},
                        {72.0, 0.0},
                        {-72.0, 0.0},
                        {0.0, 57.5},
                        {0.0, 122.5},
                        {0.0, 270.0},
                        {45.0, 90.0},
                        {-45.0, 90.0}})
    program.push_back({{"alpha1_deg", a1}, {"alpha2_deg", a2}});
  const std::string id =
      run_to_end(c, json{{"name", "limited"}, {"positions", program}}, "AU-D4", 20);
  const json d = c.call("run.diagnose", {{"run_id", id}}, 300s);
  ASSERT_FALSE(d["proposed_positions"].empty()) << d.dump();
  for (const json& p : d["proposed_positions"]) {
    const double a1 = p["alpha1_deg"];
    EXPECT_GE(a1, -100.0) << p.dump();
    EXPECT_LE(a1, 100.0) << p.dump();
  }
  // Without the stand's ranges the same recording gets proposals the stand cannot reach,
  // so the check above is one the configured ranges must pass.
  const Diagnosis unlimited = diagnose_recording(read_recording(d["recording_path"]));
  bool some_unreachable = false;
  for (const ProposedPosition& p : unlimited.proposed_positions)
    some_unreachable = some_unreachable || !reachable(p.alpha1_deg, -100, 100);
  EXPECT_TRUE(some_unreachable) << diagnose_to_json(unlimited)["proposed_positions"].dump();
  // The follow-up run of those positions starts and finishes on this stand.
  json follow_up = json::array();
  for (const json& p : d["proposed_positions"])
    follow_up.push_back({{"alpha1_deg", p["alpha1_deg"]}, {"alpha2_deg", p["alpha2_deg"]}});
  const std::string follow =
      c.call("run.start", {{"program", {{"name", "follow-up of " + id}, {"positions", follow_up}}},
                           {"unit_serial", "AU-D4"},
                           {"dwell_s", 5},
                           {"settle_s", 1}})["run_id"];
  EXPECT_EQ(test::wait_run(c, follow, test::finished, 120s)["state"], "done");
}

// Issue 14: run.diagnose of a run with 1-3 recorded positions segfaulted the daemon (an
// empty QR in the diagnosis) while it drove the stand. Now the answer is the clear
// "cannot check the model: N positions for 9 unknowns", and the daemon serves on.
TEST(DaemonDiagnose, ARunWithFewPositionsIsAClearAnswerNotACrash) {
  TempDir dir;
  auto daemon = DaemonProcess::sim(dir.path(), 300);
  Client c(socket_of(dir));
  const std::string id = c.call("run.start", {{"program", "paper9"},
                                              {"unit_serial", "AU-D5"},
                                              {"dwell_s", 20},
                                              {"settle_s", 1}})["run_id"];
  test::wait_run(
      c, id, [](const json& s) { return s.value("positions_done", 0) >= 2; }, 120s);
  c.call("run.abort", {{"run_id", id}});
  const json s = test::wait_run(c, id, test::finished, 60s);
  const int done = s["positions_done"];
  ASSERT_GE(done, 2) << s.dump();
  const auto [code, message] = error_of([&] { c.call("run.diagnose", {{"run_id", id}}, 120s); });
  EXPECT_EQ(code, -32007) << message;
  EXPECT_NE(
      message.find("cannot check the model: " + std::to_string(done) + " positions for 9 unknowns"),
      std::string::npos)
      << message;
  EXPECT_FALSE(daemon->exited()) << daemon->log();
  EXPECT_EQ(c.call("run.status", {{"run_id", id}})["run_id"], id);
}

// Whatever happens inside a diagnosis, the process that drives the stand lives on: a
// diagnosis child that dies (fault injection: it aborts, as a crash in the maths would)
// is an error answer naming the signal, and the daemon keeps serving the stand.
TEST(DaemonDiagnose, ADiagnosisThatCrashesDoesNotTakeTheDaemonDown) {
  TempDir dir;
  std::vector<std::string> args{
      "--sim",        "--socket", socket_of(dir), "--state-dir", dir.path() + "/state",
      "--time-scale", "300"};
  DaemonProcess daemon(dir.path(), args, {"STANDCALD_FAULT_DIAGNOSE_WORKER=abort"});
  daemon.wait_ready(socket_of(dir));
  Client c(socket_of(dir));
  const std::string id = run_to_end(c, "paper9", "AU-D6", 5);
  const auto [code, message] = error_of([&] { c.call("run.diagnose", {{"run_id", id}}, 120s); });
  EXPECT_EQ(code, -32603) << message;
  EXPECT_NE(message.find("died of signal " + std::to_string(SIGABRT)), std::string::npos)
      << message;
  EXPECT_NE(message.find("the daemon, the stand and the run are unaffected"), std::string::npos)
      << message;
  EXPECT_FALSE(daemon.exited()) << daemon.log();
  EXPECT_EQ(c.call("run.status", {{"run_id", id}})["state"], "done");
  // The stand still obeys an emergency stop.
  EXPECT_EQ(c.call("estop", json::object(), 5s)["estop"], true);
}
