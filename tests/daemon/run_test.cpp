// Full runs through the real standcald process on the simulated backend: the socket,
// the sequencer, the stored recording and result, kill -9 and resume, pause, abort,
// e-stop, SIGTERM, re-mount steps.
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <map>
#include <set>

#include "calib/allan.hpp"
#include "calib/averaging.hpp"
#include "calib/diagnosis/diagnosis.hpp"
#include "calib/invariant_estimator.hpp"
#include "calib/noise_model.hpp"
#include "calib/recording.hpp"
#include "calib/report.hpp"
#include "calib/simulator.hpp"
#include "daemon_process.hpp"
#include "tests/support/command.hpp"
#include "tests/support/unit_static_recording.hpp"

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

// Samples per position block, in the order of the file; fails on a position seen twice.
std::map<int, std::size_t> position_blocks(const Recording& rec) {
  std::map<int, std::size_t> counts;
  int last = -1;
  for (const RecordingSample& s : rec.samples) {
    if (s.pos != last) {
      EXPECT_EQ(counts.count(s.pos), 0u) << "position " << s.pos << " appears twice";
      last = s.pos;
    }
    ++counts[s.pos];
  }
  return counts;
}

// A config with the daemon's socket and state directory in `dir`, for a test to add to.
json config_in(const TempDir& dir) {
  return {{"socket", {{"path", socket_of(dir)}}}, {"state_dir", dir.path() + "/state"}};
}

// Writes `config` as dir/standcald.json (again, for a restart with other settings) and gives
// the arguments of a simulated daemon reading it at 100x.
std::vector<std::string> sim_daemon_args(const TempDir& dir, const json& config) {
  const std::string file = dir.path() + "/standcald.json";
  std::ofstream(file) << config.dump(2);
  return {"--config", file, "--sim", "--time-scale", "100"};
}

int error_code_of(const std::function<void()>& call) {
  try {
    call();
  } catch (const RpcError& e) {
    return e.code();
  }
  return 0;
}

}  // namespace

TEST(DaemonRun, FullPaper9RunOverTheSocket) {
  TempDir dir;
  auto daemon = DaemonProcess::sim(dir.path(), 300);
  Client c(socket_of(dir));
  EXPECT_EQ(c.hello()["protocol"], "1");
  Client events(socket_of(dir));
  events.call("subscribe", {{"events", "all"}});

  const json started = c.call("run.start", {{"program", "paper9"},
                                            {"unit_serial", "AU-0042"},
                                            {"dwell_s", 30},
                                            {"settle_s", 2},
                                            {"operator", "test"}});
  const std::string run_id = started["run_id"];
  EXPECT_EQ(started["positions"], 9);
  const json final_status = wait_run(c, run_id, finished);
  ASSERT_EQ(final_status["state"], "done") << final_status.dump() << daemon->log();
  EXPECT_EQ(final_status["positions_done"], 9);

  // Events: nine averaged positions and a state change to done.
  int averaged = 0;
  bool saw_done = false;
  while (auto n = events.next_notification(200ms)) {
    if ((*n)["method"] == "run.position_averaged") {
      ++averaged;
      EXPECT_EQ((*n)["params"]["sigma_ug"].size(), 3u);
    }
    if ((*n)["method"] == "run.state" && (*n)["params"]["state"] == "done") saw_done = true;
  }
  EXPECT_EQ(averaged, 9);
  EXPECT_TRUE(saw_done);

  // The stored recording: every position once, with t_arrive_s and approach columns.
  const json result = c.call("run.result", {{"run_id", run_id}});
  const std::string path = result["recording_path"];
  const Recording rec = read_recording(path);
  EXPECT_EQ(rec.unit_serial, "AU-0042");
  EXPECT_TRUE(rec.columns.t_arrive);
  EXPECT_TRUE(rec.columns.approach);
  const auto blocks = position_blocks(rec);
  ASSERT_EQ(blocks.size(), 9u);
  for (const auto& [pos, n] : blocks) {
    EXPECT_NEAR(static_cast<double>(n), 30 * 100, 1) << "position " << pos;
  }
  for (const RecordingSample& s : rec.samples) {
    ASSERT_TRUE(s.approach == 1 || s.approach == -1);
    ASSERT_LE(s.t_arrive_s, s.t_s);
  }

  // The result is the fit of that recording, in `standcal fit --json`'s shape, plus traceability.
  const json refit = fit_to_json(fit_invariant_joint(average_positions(rec)));
  for (const auto& name : kUnitParameterNames) {
    const std::string key(name);
    ASSERT_TRUE(result["parameters"].contains(key)) << key;
    EXPECT_EQ(result["parameters"][key], refit["parameters"][key]) << key;
  }
  EXPECT_EQ(result["estimator"], refit["estimator"]);
  EXPECT_EQ(result["positions"], 9);
  EXPECT_EQ(result["traceability"]["unit_serial"], "AU-0042");
  EXPECT_EQ(result["traceability"]["operator"], "test");
  EXPECT_EQ(result["traceability"]["stand_id"], "sim-stand");
  EXPECT_FALSE(result["traceability"]["config_hash"].get<std::string>().empty());
  EXPECT_FALSE(result["traceability"]["ended_utc"].get<std::string>().empty());

  // The estimates find the simulator's truth (noise: about 1 µg per bias at this dwell).
  const TruthModel truth = default_truth();
  for (int i = 0; i < 3; ++i) {
    const json& p =
        result["parameters"][std::string(kUnitParameterNames[static_cast<std::size_t>(i)])];
    EXPECT_NEAR(p["value"].get<double>(), truth.unit.bias_g[i] / kUg,
                8 * p["sigma"].get<double>() + 2)
        << i;
  }

  // The run index for the unit lists it.
  const json runs = c.call("runs.list", {{"unit_serial", "AU-0042"}});
  ASSERT_EQ(runs["runs"].size(), 1u);
  EXPECT_EQ(runs["runs"][0]["run_id"], run_id);
  std::ifstream index(dir.path() + "/state/units/AU-0042.json");
  EXPECT_EQ(json::parse(index)["runs"][0], run_id);
}

// Issue 21: a unit's configured bias wander is what the run's fits weight with when the
// run alone cannot show one (nine positions leave the joint fit no residual to estimate
// it from), and the result says so. Its correlation time, one value or a range (what
// `standcal noise` of a static recording gives), reaches the fits as given. The recording's
// header keeps it, so that every later fit of the run weighs as the run did.
namespace {

struct ConfiguredRun {
  json result;
  RecordedUnitWander recorded;    // what the recording's header says
  std::string static_curves;      // ... of the unit's static recording's curves (its value)
  double static_tau_floor_s = 0;  // ... of the floor they put under the correlation time
  std::string report;             // `standcal run result RUN_ID`
  json full_refit;                // `standcal fit RECORDING --method full --json`
  std::string log;
};

ConfiguredRun run_with_configured_wander(const json& unit) {
  TempDir dir;
  const json config = {
      {"socket", {{"path", socket_of(dir)}}}, {"state_dir", dir.path() + "/state"}, {"unit", unit}};
  const std::string file = dir.path() + "/standcald.json";
  std::ofstream(file) << config.dump(2);
  DaemonProcess daemon(dir.path(), {"--config", file, "--sim", "--time-scale", "300"});
  daemon.wait_ready(socket_of(dir));
  Client c(socket_of(dir));
  const json started = c.call("run.start", {{"program", "paper9"},
                                            {"unit_serial", "AU-7"},
                                            {"dwell_s", 10},
                                            {"settle_s", 1},
                                            {"operator", "test"}});
  const std::string run_id = started["run_id"];
  const json final_status = wait_run(c, run_id, finished);
  ConfiguredRun run;
  run.log = daemon.log();
  EXPECT_EQ(final_status["state"], "done") << final_status.dump() << run.log;
  run.result = c.call("run.result", {{"run_id", run_id}});
  const Recording rec = read_recording(run.result["recording_path"]);
  run.recorded = rec.unit_wander;
  run.static_curves = rec.header_value(kHeaderUnitStaticCurves);
  run.static_tau_floor_s = rec.unit_static_tau_floor_s;
  const test::CommandOutcome shown =
      test::standcal_cli("run result " + run_id + " --socket " + socket_of(dir));
  EXPECT_EQ(shown.exit_code, 0) << shown.output;
  run.report = shown.output;
  const test::CommandOutcome refit = test::standcal_cli(
      "fit " + run.result["recording_path"].get<std::string>() + " --method full --json");
  EXPECT_EQ(refit.exit_code, 0) << refit.output;
  const std::size_t brace = refit.output.find('{');
  run.full_refit =
      json::parse(brace == std::string::npos ? "" : refit.output.substr(brace), nullptr, false);
  return run;
}

// `standcal run result`'s report, which refits the recording, gives the bias_x sigma of the
// run's own result: it weighs as the run did.
void expect_the_report_gives_the_results_bias_x_sigma(const ConfiguredRun& run) {
  char sigma[32];
  std::snprintf(sigma, sizeof sigma, " %.2f\n",
                run.result["parameters"]["bias_x"]["sigma"].get<double>());
  const auto bias_x = run.report.find("  bias_x ");
  ASSERT_NE(bias_x, std::string::npos) << run.report;
  const std::string line = run.report.substr(bias_x, run.report.find('\n', bias_x) - bias_x + 1);
  EXPECT_NE(line.find(sigma), std::string::npos)
      << "the result's bias_x sigma" << sigma << "in " << line;
}

}  // namespace

TEST(DaemonRun, TheFitsAssumeTheUnitsConfiguredBiasWander) {
  const ConfiguredRun run =
      run_with_configured_wander({{"bias_instability_ug", 5}, {"bias_instability_tau_s", 600}});
  const json& noise = run.result["noise"];
  EXPECT_EQ(noise["model"], "gauss_markov") << noise.dump(2) << run.log;
  EXPECT_EQ(noise["source"], "specified");
  EXPECT_DOUBLE_EQ(noise["wander_ug"][0].get<double>(), 5);
  EXPECT_DOUBLE_EQ(noise["tau_s"].get<double>(), 600);
  EXPECT_EQ(noise["tau_given"], true);
  EXPECT_EQ(noise["unit_wander_from"], "header");
  // The full vector (27 rows) estimates the wander's size, at the configured time.
  const std::string full_how = run.result["full_vector"]["noise"]["how"];
  EXPECT_NE(full_how.find("at the given correlation time 600 s"), std::string::npos) << full_how;
  EXPECT_TRUE(noise["allan"]["axes"]["x"]["white_density_ug_rthz"].is_number());
  // The recording keeps what the run was made with, and `standcal run result`, which refits
  // it, prints the report of the same weighting: it had printed a white fit's, whose biases'
  // sigmas the run's result did not give (this test failed so before the fix).
  EXPECT_DOUBLE_EQ(run.recorded.size_ug, 5);
  EXPECT_DOUBLE_EQ(run.recorded.tau_s, 600);
  EXPECT_EQ(run.recorded.tau_max_s, 0);
  EXPECT_NE(run.report.find("the specified bias wander its run was made with"), std::string::npos)
      << run.report;
  expect_the_report_gives_the_results_bias_x_sigma(run);
}

// unit.static_recording: the wander its Allan curves pin (two hours of a 3 ug wander of 60 s) is
// what the runs' fits weigh with; the recording's header keeps it and says where it came from,
// the result says so, and the start is logged with what the file gave.
TEST(DaemonRun, TheFitsTakeTheWanderTheUnitsStaticRecordingPins) {
  const std::string pinned = ::testing::TempDir() + "/standcal-run-static-pinned.csv";
  write_recording(test::unit_static_recording(7200, 3, 60, 7), pinned);
  const ConfiguredRun run = run_with_configured_wander({{"static_recording", pinned}});
  const json& noise = run.result["noise"];
  EXPECT_EQ(noise["unit_wander_from"], "header") << noise.dump(2) << run.log;
  EXPECT_EQ(noise["tau_given"], true) << noise.dump(2);
  EXPECT_NEAR(run.recorded.size_ug, 3, 1.2);
  // Each axis's own size too, the largest of which is the size.
  EXPECT_FALSE(run.recorded.size_axes_ug.isZero());
  EXPECT_DOUBLE_EQ(run.recorded.size_axes_ug.maxCoeff(), run.recorded.size_ug);
  EXPECT_LT(run.recorded.tau_s, 60 * 1.5);  // the range the recording allows holds 60 s
  EXPECT_GT(run.recorded.tau_max_s, 60 / 1.5);
  ASSERT_TRUE(run.result.contains("unit_wander_source")) << run.result.dump(2);
  EXPECT_NE(run.result["unit_wander_source"].get<std::string>().find(
                "the unit's static recording " + pinned + " (2 h static) gave its wander"),
            std::string::npos)
      << run.result["unit_wander_source"];
  EXPECT_NE(run.log.find("unit.static_recording: the unit's static recording " + pinned),
            std::string::npos)
      << run.log;
  std::remove(pinned.c_str());
}

// One whose curves show no wander gives the runs no wander but its curves, which each run's
// header carries (kHeaderUnitStaticCurves): the run's fits weigh them as a bound on the wander
// their sigmas allow for, as `standcal fit --unit-static-recording` does, and so does every
// later fit of the recording. The header says so too: `run.result`'s unit_wander_source and
// `standcal run result`'s report beneath its Noise line, where a run's own wander is then
// advised on as beside a static recording (not by the unit.bias_instability_* the daemon
// refuses beside it). Until 2026-12-07 the runs carried no curves, and their fits weighed none.
TEST(DaemonRun, AStaticRecordingThatPinsNoWanderBoundsEachRunsWander) {
  const std::string still = ::testing::TempDir() + "/standcal-run-static-still.csv";
  write_recording(test::unit_static_recording(7200, 0, 300, 4), still);
  const ConfiguredRun run = run_with_configured_wander({{"static_recording", still}});
  EXPECT_FALSE(run.result["noise"].contains("unit_wander_from")) << run.result["noise"].dump(2);
  EXPECT_EQ(run.recorded.size_ug, 0);
  ASSERT_FALSE(run.static_curves.empty()) << "the header carries the curves";
  EXPECT_GT(parse_wander_curves(run.static_curves).curves_end_s, 60);
  const json& full_noise = run.result["full_vector"]["noise"];
  EXPECT_EQ(full_noise["sigmas_allowance_allan_curves_from"], "static_recording")
      << full_noise.dump(2);
  // A later fit of the recording weighs them as the run's did: the full vector's sigmas alike.
  // (The joint fit's nine rows of paper9 estimate no wander, so `run result`'s report, a joint
  // fit's, has no wander to bound.)
  ASSERT_TRUE(run.full_refit.is_object() && run.full_refit.contains("noise") &&
              run.full_refit.contains("parameters"))
      << run.full_refit.dump(2);
  EXPECT_EQ(run.full_refit["noise"].value("sigmas_allowance_allan_curves_from", ""),
            "static_recording");
  EXPECT_DOUBLE_EQ(run.full_refit["parameters"]["bias_x"].value("sigma", 0.0),
                   run.result["full_vector"]["parameters"]["bias_x"]["sigma"].get<double>());
  const std::string gave =
      "the unit's static recording " + still + " (2 h static) gave its curves, to bound the wander";
  ASSERT_TRUE(run.result.contains("unit_wander_source")) << run.result.dump(2);
  EXPECT_NE(run.result["unit_wander_source"].get<std::string>().find(gave), std::string::npos)
      << run.result["unit_wander_source"];
  EXPECT_NE(run.report.find("            its run, by standcald's unit.static_recording: " + gave),
            std::string::npos)
      << run.report;
  std::remove(still.c_str());
}

// One whose curves see a wander they do not pin (two hours of a 30 ug wander of 1200 s) gives
// the runs the floor they put under its correlation time, which each run's header carries
// (kHeaderUnitStaticTauFloorS): the run's fits take it where the run shows the wander at those
// times, and set it aside, saying so, where it does not (this simulated unit has no wander), as
// every later fit of the recording does. Until 2026-12-07 such a recording gave the runs
// nothing.
TEST(DaemonRun, AStaticRecordingThatSeesAWanderItDoesNotPinPutsItsFloorInEachRunsHeader) {
  const std::string slow = ::testing::TempDir() + "/standcal-run-static-slow.csv";
  write_recording(test::unit_static_recording(7200, 30, 1200, test::kSlowWanderStaticSeed), slow);
  const ConfiguredRun run = run_with_configured_wander({{"static_recording", slow}});
  EXPECT_EQ(run.recorded.size_ug, 0);
  EXPECT_GT(run.static_tau_floor_s, 60) << run.log;
  EXPECT_TRUE(run.static_curves.empty());
  // The run's own floor, set aside: the words name its value.
  const std::string full_how = run.result["full_vector"]["noise"].value("how", "");
  EXPECT_NE(full_how.find(tau_floor_set_aside_words(run.static_tau_floor_s)), std::string::npos)
      << full_how;
  ASSERT_TRUE(run.full_refit.is_object());
  EXPECT_EQ(run.full_refit.value("noise", json::object()).value("how", ""), full_how);
  ASSERT_TRUE(run.result.contains("unit_wander_source")) << run.result.dump(2);
  EXPECT_NE(run.result["unit_wander_source"].get<std::string>().find(
                "(2 h static) gave a floor under the wander's correlation time: its Allan curves "
                "see a wander they do not pin"),
            std::string::npos)
      << run.result["unit_wander_source"];
  std::remove(slow.c_str());
}

TEST(DaemonRun, TheFitsTakeTheUnitsCorrelationTimeAsARange) {
  const ConfiguredRun run = run_with_configured_wander({{"bias_instability_ug", 5},
                                                        {"bias_instability_tau_s", 300},
                                                        {"bias_instability_tau_max_s", 1200}});
  const json& noise = run.result["noise"];
  EXPECT_EQ(noise["source"], "specified") << noise.dump(2) << run.log;
  EXPECT_DOUBLE_EQ(noise["tau_s"].get<double>(), 600);  // the range's log-middle
  EXPECT_EQ(noise["tau_given_s"], json::array({300.0, 1200.0}));
  const std::string full_how = run.result["full_vector"]["noise"]["how"];
  EXPECT_NE(full_how.find("at the given correlation times 300-1200 s"), std::string::npos)
      << full_how;
  EXPECT_DOUBLE_EQ(run.recorded.tau_s, 300);
  EXPECT_DOUBLE_EQ(run.recorded.tau_max_s, 1200);
}

TEST(DaemonRun, KillNineMidRunThenResumeRecordsEveryPositionOnce) {
  TempDir dir;
  std::string run_id;
  {
    auto daemon = DaemonProcess::sim(dir.path(), 100);
    Client c(socket_of(dir));
    run_id = c.call("run.start", {{"program", "paper9"},
                                  {"unit_serial", "AU-7"},
                                  {"dwell_s", 40},
                                  {"settle_s", 1}})["run_id"];
    wait_run(c, run_id,
             [](const json& s) { return s["positions_done"].get<int>() >= 3 || finished(s); });
    daemon->kill_now(SIGKILL);  // mid-run: the socket file and the recording stay as they were
  }
  auto daemon = DaemonProcess::sim(dir.path(), 100);  // replaces the stale socket
  Client c(socket_of(dir));
  const json after = c.call("run.status", {{"run_id", run_id}});
  ASSERT_EQ(after["state"], "interrupted") << after.dump();
  const int done_before = after["positions_done"];
  EXPECT_GE(done_before, 3);
  EXPECT_LT(done_before, 9);

  const json resumed = c.call("run.resume", json::object());  // the newest resumable run
  EXPECT_EQ(resumed["run_id"], run_id);
  EXPECT_EQ(resumed["position"], done_before + 1);
  const json final_status = wait_run(c, run_id, finished);
  ASSERT_EQ(final_status["state"], "done") << final_status.dump() << daemon->log();

  const Recording rec = read_recording(dir.path() + "/state/runs/" + run_id + "/recording.csv");
  EXPECT_TRUE(rec.warnings.empty());
  const auto blocks = position_blocks(rec);
  ASSERT_EQ(blocks.size(), 9u);
  for (int pos = 0; pos < 9; ++pos) {
    ASSERT_EQ(blocks.count(pos), 1u);
    EXPECT_NEAR(static_cast<double>(blocks.at(pos)), 40 * 100, 1) << "position " << pos;
  }
  const json result = c.call("run.result", {{"run_id", run_id}});
  EXPECT_EQ(result["positions"], 9);
}

// Issue 21: the drift rule of a resumed run pools the dwells its recording holds (cut back to
// the positions done), for a unit whose output filter correlates its samples (five periods at
// 100 Hz), and the run finishes with the rule at 3 times what the noise explains. It allows
// for the unit's bias wander the run was begun with (its recording's header, as its fits),
// not one configured since: it had read the live configuration.
TEST(DaemonRun, AResumedRunsDriftRulePoolsTheDwellsOfItsRecording) {
  TempDir dir;
  TruthModel truth = default_truth();
  truth.noise.output_filter_tau_s = 0.05;
  save_truth(truth, dir.path() + "/filtered-unit.json");
  json config = config_in(dir);
  config["sim"] = {{"truth", dir.path() + "/filtered-unit.json"}};
  config["unit"] = {{"bias_instability_ug", 5}, {"bias_instability_tau_s", 600}};
  config["run"] = {{"stability", {{"trend_limit_sigmas", 3}}}};
  std::string run_id;
  {
    DaemonProcess daemon(dir.path(), sim_daemon_args(dir, config));
    daemon.wait_ready(socket_of(dir));
    Client c(socket_of(dir));
    run_id = c.call("run.start", {{"program", "paper9"},
                                  {"unit_serial", "AU-8"},
                                  {"dwell_s", 4},
                                  {"settle_s", 1}})["run_id"];
    wait_run(c, run_id,
             [](const json& s) { return s["positions_done"].get<int>() >= 3 || finished(s); });
    daemon.kill_now(SIGKILL);
  }
  config.erase("unit");  // the wander no longer configured
  DaemonProcess daemon(dir.path(), sim_daemon_args(dir, config));
  daemon.wait_ready(socket_of(dir));
  Client c(socket_of(dir));
  const int done_before = c.call("run.status", {{"run_id", run_id}})["positions_done"];
  ASSERT_GE(done_before, 3);
  c.call("run.resume", {{"run_id", run_id}});
  const json final_status = wait_run(c, run_id, finished);
  EXPECT_EQ(final_status["state"], "done") << final_status.dump() << daemon.log();
  EXPECT_NE(daemon.log().find("the drift rule pools the " + std::to_string(done_before) +
                              " dwells of its recording (samples' correlation widens the white "
                              "noise x 3."),
            std::string::npos)
      << daemon.log();
  EXPECT_NE(daemon.log().find("the drift rule allows for the unit's bias wander the run was "
                              "begun with, 5 µg at tau 600 s (its recording's header), not the "
                              "configured none"),
            std::string::npos)
      << daemon.log();
}

// The mirror: a run begun with no wander configured, resumed by a daemon configured with one
// since, is weighed as its header says (none), by its end fits, its drift rule and run.diagnose,
// as every later fit of its recording is. Until 2026-12-07 a header without the wander's keys
// was taken for a run begun before headers carried it, and the configured wander stood in: the
// run's result was not what `standcal fit` of its recording gives (the first checks failed).
TEST(DaemonRun, ARunBegunWithNoWanderConfiguredIsWeighedAsItsHeaderSaysAfterResume) {
  TempDir dir;
  json config = config_in(dir);
  config["run"] = {{"stability", {{"trend_limit_sigmas", 3}}}};
  std::string run_id;
  {
    DaemonProcess daemon(dir.path(), sim_daemon_args(dir, config));
    daemon.wait_ready(socket_of(dir));
    Client c(socket_of(dir));
    // Twelve distinct orientations on one mount: enough for the diagnosis to test its terms.
    json twelve = json::array();
    for (double a1_deg : {0.0, 60.0, 120.0, 180.0, 240.0, 300.0})
      twelve.push_back({{"alpha1_deg", a1_deg}, {"alpha2_deg", 0.0}});
    for (double a2_deg : {45.0, 90.0, 135.0, 225.0, 270.0, 315.0})
      twelve.push_back({{"alpha1_deg", 0.0}, {"alpha2_deg", a2_deg}});
    run_id = c.call(
        "run.start",
        {{"program", twelve}, {"unit_serial", "AU-8"}, {"dwell_s", 4}, {"settle_s", 1}})["run_id"];
    wait_run(c, run_id,
             [](const json& s) { return s["positions_done"].get<int>() >= 3 || finished(s); });
    daemon.kill_now(SIGKILL);
  }
  config["unit"] = {{"bias_instability_ug", 5}, {"bias_instability_tau_s", 600}};
  DaemonProcess daemon(dir.path(), sim_daemon_args(dir, config));
  daemon.wait_ready(socket_of(dir));
  Client c(socket_of(dir));
  c.call("run.resume", {{"run_id", run_id}});
  const json final_status = wait_run(c, run_id, finished);
  ASSERT_EQ(final_status["state"], "done") << final_status.dump() << daemon.log();
  const json result = c.call("run.result", {{"run_id", run_id}});
  const std::string recording = result["recording_path"];
  EXPECT_EQ(read_recording(recording).header_value(kHeaderUnitWanderUg), "0")
      << "none configured, and said so";
  EXPECT_FALSE(result["full_vector"]["noise"].contains("unit_wander_from"))
      << result["full_vector"]["noise"].dump(2);
  const test::CommandOutcome refit =
      test::standcal_cli("fit " + recording + " --method full --json");
  ASSERT_EQ(refit.exit_code, 0) << refit.output;
  const json full = json::parse(refit.output.substr(refit.output.find('{')));
  EXPECT_EQ(result["full_vector"]["parameters"]["bias_x"]["sigma"],
            full["parameters"]["bias_x"]["sigma"]);
  EXPECT_NE(daemon.log().find("the drift rule allows for the unit's bias wander the run was "
                              "begun with, none (its recording's header), not the configured 5 "
                              "µg at tau 600 s"),
            std::string::npos)
      << daemon.log();
  // run.diagnose: what `standcal diagnose` of the recording gives.
  const json diagnosed = c.call("run.diagnose", {{"run_id", run_id}}, 300s);
  const json local = diagnose_to_json(diagnose_recording(read_recording(recording)));
  EXPECT_EQ(diagnosed["verdict"], local["verdict"]);
  EXPECT_EQ(diagnosed["noise"], local["noise"]) << diagnosed["noise"].dump(2);
}

// A run begun under a rate at which its dwells fit what a dwell holds (kMaxDwellSamples), and
// resumed by a daemon configured for a higher one, is refused before the stand moves: the
// limit run.start applies holds for run.resume too.
TEST(DaemonRun, AResumeWhoseDwellsNoLongerFitIsRefusedNamingThem) {
  TempDir dir;
  json config = config_in(dir);
  config["unit"] = {{"sample_rate_hz", 100}};
  std::string run_id;
  {
    DaemonProcess daemon(dir.path(), sim_daemon_args(dir, config));
    daemon.wait_ready(socket_of(dir));
    Client c(socket_of(dir));
    run_id = c.call("run.start",
                    {{"program", "paper9"}, {"unit_serial", "AU-R"}, {"dwell_s", 30000}})["run_id"];
    daemon.kill_now(SIGKILL);
  }
  config["unit"]["sample_rate_hz"] = 200;
  DaemonProcess daemon(dir.path(), sim_daemon_args(dir, config));
  daemon.wait_ready(socket_of(dir));
  Client c(socket_of(dir));
  try {
    c.call("run.resume", {{"run_id", run_id}});
    ADD_FAILURE() << "resumed a run whose dwells hold 6000000 samples";
  } catch (const RpcError& e) {
    EXPECT_EQ(e.code(), -32007) << e.what();
    EXPECT_NE(std::string(e.what()).find("run " + run_id +
                                         " cannot be resumed: position 1's dwell of 30000 s at "
                                         "200 Hz would be 6000000 samples"),
              std::string::npos)
        << e.what();
  }
  EXPECT_NE(c.call("run.status", {{"run_id", run_id}})["state"], "running");
}

TEST(DaemonRun, OneRunAtATimeAndTheStandIsBusyDuringIt) {
  TempDir dir;
  auto daemon = DaemonProcess::sim(dir.path(), 50);
  Client c(socket_of(dir));
  const std::string run_id = c.call(
      "run.start", {{"program", "paper9"}, {"unit_serial", "AU-1"}, {"dwell_s", 60}})["run_id"];
  Client other(socket_of(dir));
  EXPECT_EQ(error_code_of([&] {
              other.call("run.start", {{"program", "paper9"}, {"unit_serial", "AU-2"}});
            }),
            -32001);
  EXPECT_EQ(error_code_of([&] {
              other.call("stand.move", {{"alpha1_deg", 10}, {"alpha2_deg", 0}});
            }),
            -32001);
  EXPECT_EQ(error_code_of([&] { other.call("unit.read", {{"seconds", 1}}); }), -32001);
  const json status = other.call("status");
  EXPECT_EQ(status["run"]["run_id"], run_id);
  c.call("run.abort");
  const json s = wait_run(c, run_id, finished);
  EXPECT_EQ(s["state"], "aborted");
}

TEST(DaemonRun, PauseLeavesTheStandStoppedAndResumeCompletesTheRun) {
  TempDir dir;
  auto daemon = DaemonProcess::sim(dir.path(), 200);
  Client c(socket_of(dir));
  const std::string run_id = c.call(
      "run.start",
      {{"program", "paper9"}, {"unit_serial", "AU-3"}, {"dwell_s", 30}, {"settle_s", 1}})["run_id"];
  wait_run(c, run_id, [](const json& s) { return s.value("positions_done", 0) >= 2; });
  c.call("run.pause");
  const json paused =
      wait_run(c, run_id, [](const json& s) { return s.value("state", "") == "paused"; });
  const int done_at_pause = paused["positions_done"];
  std::this_thread::sleep_for(300ms);
  const json still = c.call("run.status", {{"run_id", run_id}});
  EXPECT_EQ(still["state"], "paused");
  EXPECT_EQ(still["positions_done"], done_at_pause);  // nothing measured while paused
  const json stand_status = c.call("status");
  ASSERT_TRUE(stand_status.contains("stand")) << stand_status.dump();
  for (const json& axis : stand_status["stand"].value("axes", json::array())) {
    EXPECT_NE(axis.value("mode", ""), "moving") << axis.dump();
  }
  EXPECT_EQ(error_code_of([&] { c.call("run.pause"); }), -32007);
  c.call("run.resume");
  const json s = wait_run(c, run_id, finished);
  ASSERT_EQ(s["state"], "done") << daemon->log();
  const auto blocks = position_blocks(read_recording(s["recording_path"]));
  EXPECT_EQ(blocks.size(), 9u);
}

TEST(DaemonRun, EstopFromAnyClientStopsTheRunAndLatches) {
  TempDir dir;
  auto daemon = DaemonProcess::sim(dir.path(), 50);
  Client c(socket_of(dir));
  const std::string run_id = c.call(
      "run.start", {{"program", "paper9"}, {"unit_serial", "AU-4"}, {"dwell_s", 60}})["run_id"];
  wait_run(c, run_id,
           [](const json& s) { return s["phase"] == "moving" || s["phase"] == "sampling"; });
  Client other(socket_of(dir));
  const json stopped = other.call("estop", json::object(), 5s);
  EXPECT_EQ(stopped["estop"], true);
  const json s = wait_run(c, run_id, finished);
  EXPECT_EQ(s["state"], "faulted");
  EXPECT_NE(s["reason"].get<std::string>().find("emergency stop"), std::string::npos);
  EXPECT_EQ(c.call("status")["stand"]["estop_latched"], true);
  EXPECT_EQ(error_code_of([&] {
              c.call("stand.move", {{"alpha1_deg", 1}, {"alpha2_deg", 1}});
            }),
            -32004);
  EXPECT_EQ(error_code_of([&] { c.call("run.resume"); }), -32004);
  c.call("estop.reset");
  c.call("stand.enable");
  c.call("stand.home", json::object(), 60s);
  const json moved = c.call("stand.move", {{"alpha1_deg", 90}, {"alpha2_deg", -45}}, 60s);
  EXPECT_NEAR(moved["alpha1_deg"].get<double>(), 90, 0.01);
  EXPECT_NEAR(moved["alpha2_deg"].get<double>(), -45, 0.01);
}

// docs/protocol.md: -32007 when the run itself is already running, -32001 when another
// run holds the stand. Resuming a faulted run while another was active answered -32007.
TEST(DaemonRun, ResumingAnotherRunWhileOneIsActiveIsBusy) {
  TempDir dir;
  auto daemon = DaemonProcess::sim(dir.path(), 50);
  Client c(socket_of(dir));
  const std::string faulted = c.call(
      "run.start", {{"program", "paper9"}, {"unit_serial", "AU-6"}, {"dwell_s", 60}})["run_id"];
  wait_run(c, faulted,
           [](const json& s) { return s["phase"] == "moving" || s["phase"] == "sampling"; });
  c.call("estop", json::object(), 5s);
  ASSERT_EQ(wait_run(c, faulted, finished)["state"], "faulted");
  c.call("estop.reset");
  const std::string active = c.call(
      "run.start", {{"program", "paper9"}, {"unit_serial", "AU-7"}, {"dwell_s", 60}})["run_id"];
  wait_run(c, active, [](const json& s) { return s["state"] == "running"; });
  try {
    c.call("run.resume", {{"run_id", faulted}});
    ADD_FAILURE() << "resuming " << faulted << " while " << active << " runs was accepted";
  } catch (const RpcError& e) {
    EXPECT_EQ(e.code(), -32001) << e.what();
    EXPECT_NE(std::string(e.what()).find(active), std::string::npos) << e.what();
  }
  EXPECT_EQ(error_code_of([&] {
              c.call("run.resume", {{"run_id", active}});
            }),
            -32007)
      << "the run itself";
  // The same while the active run is paused: resume must not wake the paused one instead.
  c.call("run.pause");
  wait_run(c, active, [](const json& s) { return s["state"] == "paused"; });
  EXPECT_EQ(error_code_of([&] { c.call("run.resume", {{"run_id", faulted}}); }), -32001);
  EXPECT_EQ(c.call("run.status", {{"run_id", active}})["state"], "paused");
  c.call("run.abort");
}

// The journal must say who pressed the emergency stop (it used to say "a client").
TEST(DaemonRun, TheEstopLogLineNamesThePeer) {
  TempDir dir;
  auto daemon = DaemonProcess::sim(dir.path(), 50, {"--tcp-port", "0"});
  Client c(socket_of(dir));
  c.call("estop", json::object(), 5s);
  const std::string unix_peer = "EMERGENCY STOP requested by uid " + std::to_string(::geteuid()) +
                                " gid " + std::to_string(::getegid()) + " pid " +
                                std::to_string(::getpid()) + " (";
  EXPECT_NE(daemon->log().find(unix_peer), std::string::npos) << daemon->log();
  const std::string log = daemon->log();
  const auto at = log.find("standcald: tcp port ");
  ASSERT_NE(at, std::string::npos) << log;
  const int port = std::atoi(log.c_str() + at + 20);
  Client tcp("tcp://127.0.0.1:" + std::to_string(port));
  tcp.call("estop", json::object(), 5s);
  EXPECT_NE(daemon->log().find("EMERGENCY STOP requested by tcp 127.0.0.1:"), std::string::npos)
      << daemon->log();
}

// A duration shorter than one sample period read nothing and answered a mean of 0.
TEST(DaemonRun, UnitReadRefusesADurationThatHoldsNoSample) {
  TempDir dir;
  auto daemon = DaemonProcess::sim(dir.path(), 50);
  Client c(socket_of(dir));
  for (const double seconds : {1e-300, 0.005}) {
    try {
      const json r = c.call("unit.read", {{"seconds", seconds}});
      ADD_FAILURE() << seconds << " s answered " << r.dump();
    } catch (const RpcError& e) {
      EXPECT_EQ(e.code(), -32602) << e.what();
      EXPECT_NE(std::string(e.what()).find(
                    "must be between 0.01 (one sample at unit.sample_rate_hz 100 Hz)"),
                std::string::npos)
          << e.what();
    }
  }
  EXPECT_GE(c.call("unit.read", {{"seconds", 0.05}})["samples"].get<int>(), 1);
}

TEST(DaemonRun, SigtermStopsTheStandAndLeavesTheRunResumable) {
  TempDir dir;
  std::string run_id;
  {
    auto daemon = DaemonProcess::sim(dir.path(), 100);
    Client c(socket_of(dir));
    run_id = c.call("run.start",
                    {{"program", "paper9"}, {"unit_serial", "AU-5"}, {"dwell_s", 30}})["run_id"];
    wait_run(c, run_id, [](const json& s) { return s["positions_done"].get<int>() >= 1; });
    const int status = daemon->kill_now(SIGTERM);
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << daemon->log();
    EXPECT_NE(daemon->log().find("stopping and disabling the stand axes"), std::string::npos);
    EXPECT_FALSE(std::filesystem::exists(socket_of(dir)));  // removed on a clean exit
  }
  auto daemon = DaemonProcess::sim(dir.path(), 300);
  Client c(socket_of(dir));
  EXPECT_EQ(c.call("run.status", {{"run_id", run_id}})["state"], "interrupted");
  c.call("run.resume", {{"run_id", run_id}});
  EXPECT_EQ(wait_run(c, run_id, finished)["state"], "done");
}

TEST(DaemonRun, Classic24WaitsForTheOperatorAtEachRemount) {
  TempDir dir;
  auto daemon = DaemonProcess::sim(dir.path(), 500);
  Client c(socket_of(dir));
  const std::string run_id = c.call("run.start", {{"program", "classic24"},
                                                  {"unit_serial", "AU-6"},
                                                  {"dwell_s", 10},
                                                  {"settle_s", 1}})["run_id"];
  int confirmations = 0;
  for (;;) {
    const json s = wait_run(
        c, run_id, [](const json& x) { return x["state"] == "waiting_operator" || finished(x); });
    if (s["state"] != "waiting_operator") {
      ASSERT_EQ(s["state"], "done") << s.dump() << daemon->log();
      break;
    }
    c.call("operator.confirm");
    ++confirmations;
    ASSERT_LE(confirmations, 2);
  }
  EXPECT_EQ(confirmations, 2);  // x -> y -> z
  const Recording rec = read_recording(dir.path() + "/state/runs/" + run_id + "/recording.csv");
  EXPECT_TRUE(rec.columns.mount);
  EXPECT_EQ(position_blocks(rec).size(), 24u);
  EXPECT_EQ(c.call("run.result", {{"run_id", run_id}})["positions"], 24);
}

TEST(DaemonRun, UnknownRunsAndBadProgrammesAreClearErrors) {
  TempDir dir;
  auto daemon = DaemonProcess::sim(dir.path(), 100);
  Client c(socket_of(dir));
  EXPECT_EQ(error_code_of([&] { c.call("run.result", {{"run_id", "nope"}}); }), -32006);
  EXPECT_EQ(error_code_of([&] {
              c.call("run.start", {{"program", "paper10"}, {"unit_serial", "AU"}});
            }),
            -32006);
  EXPECT_EQ(error_code_of([&] {
              c.call("run.start", {{"program", "../etc/passwd"}, {"unit_serial", "AU"}});
            }),
            -32602);
  EXPECT_EQ(error_code_of([&] { c.call("run.start", {{"program", "paper9"}}); }), -32602);
  EXPECT_EQ(error_code_of([&] { c.call("run.resume"); }), -32006);
  EXPECT_EQ(error_code_of([&] { c.call("run.pause"); }), -32007);
  EXPECT_EQ(error_code_of([&] {
              c.call("stand.move", {{"alpha1_deg", 1}, {"alpha2_deg", 2}});
            }),
            -32007);  // not enabled
  c.call("stand.enable");
  EXPECT_EQ(error_code_of([&] {
              c.call("stand.move", {{"alpha1_deg", 1}, {"alpha2_deg", 2}});
            }),
            -32002);  // not homed
  c.call("stand.home", json::object(), 60s);
  EXPECT_EQ(error_code_of([&] {
              c.call("stand.move", {{"alpha1_deg", "ninety"}, {"alpha2_deg", 2}});
            }),
            -32602);
  EXPECT_EQ(error_code_of([&] { c.call("unit.read", {{"seconds", -1}}); }), -32602);
  const json read = c.call("unit.read", {{"seconds", 2}});
  EXPECT_NEAR(read["samples"].get<double>(), 200, 1);
  EXPECT_NEAR(read["axes"]["y"]["mean_mps2"].get<double>(), 9.81, 0.05);  // y up at (0, 0)
  // Inline positions run like a named programme.
  const json inline_run =
      c.call("run.start", {{"program", json::array({{{"alpha1_deg", 0}, {"alpha2_deg", 0}},
                                                    {{"alpha1_deg", 90}, {"alpha2_deg", 0}}})},
                           {"unit_serial", "AU-8"},
                           {"dwell_s", 5},
                           {"settle_s", 0}});
  const json s = wait_run(c, inline_run["run_id"], finished);
  EXPECT_EQ(s["positions_done"], 2);
}

TEST(DaemonCli, RunStartWaitPrintsTheResultOfARunThroughTheDaemon) {
  TempDir dir;
  auto daemon = DaemonProcess::sim(dir.path(), 300);
  const test::CommandOutcome refused =
      test::standcal_cli("run start paper9 --unit AU-CLI --warmup-s -1 --socket " + socket_of(dir));
  EXPECT_NE(refused.exit_code, 0);
  EXPECT_NE(refused.output.find("--warmup-s"), std::string::npos) << refused.output;
  // The spellings before --unit-serial, --dwell-s and --settle-s still work (scripts).
  const test::CommandOutcome run = test::standcal_cli(
      "run start paper9 --unit AU-CLI --unit-type QA-7 --dwell 20 "
      "--settle 1 --warmup-s 30 --wait --json --socket " +
      socket_of(dir));
  ASSERT_EQ(run.exit_code, 0) << run.output;
  // --json --wait prints the events as they come, then the result (pretty-printed, last).
  const auto start = run.output.rfind("\n{\n");
  ASSERT_NE(start, std::string::npos) << run.output;
  const json result = json::parse(run.output.substr(start + 1));
  EXPECT_EQ(result["positions"], 9);
  EXPECT_EQ(result["traceability"]["unit_serial"], "AU-CLI");
  EXPECT_EQ(result["traceability"]["unit_type"], "QA-7");
  EXPECT_NE(run.output.find("run.position_averaged"), std::string::npos);

  const test::CommandOutcome runs = test::standcal_cli("runs --socket " + socket_of(dir));
  EXPECT_EQ(runs.exit_code, 0);
  EXPECT_NE(runs.output.find("AU-CLI"), std::string::npos) << runs.output;
  EXPECT_NE(runs.output.find("done"), std::string::npos) << runs.output;

  // The unit type travels with the run: run.status, the recording header, and the
  // certificate, which picks that type's limits from a file that has two.
  Client c(socket_of(dir));
  const json status = c.call("run.status");
  EXPECT_EQ(status["unit_type"], "QA-7");
  const Recording recording = read_recording(status["recording_path"]);
  EXPECT_EQ(recording.header_value("unit_type"), "QA-7");
  EXPECT_DOUBLE_EQ(recording.warmup_s, 30);  // --warmup-s
  const std::string limits = dir.path() + "/limits.json";
  std::ofstream(limits) << R"({"format": "standcal-limits/1", "unit_types": {
      "QA-7": {"parameters": {"bias": {"max_abs": 1000}}},
      "QA-8": {"parameters": {"bias": {"max_abs": 1}}}}})";
  const std::string cert = dir.path() + "/cert.html";
  const test::CommandOutcome certificate =
      test::standcal_cli("certificate " + status["run_id"].get<std::string>() + " --state-dir " +
                         dir.path() + "/state --limits " + limits + " -o " + cert);
  ASSERT_EQ(certificate.exit_code, 0) << certificate.output;
  std::ifstream in(cert);
  const std::string html(std::istreambuf_iterator<char>(in), {});
  EXPECT_NE(html.find(">QA-7<"), std::string::npos) << "the run's unit type names the limits";
}
