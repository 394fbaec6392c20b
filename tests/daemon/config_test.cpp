// standcald's configuration: defaults, the keys it reads, and errors that name the key.
#include <gtest/gtest.h>

#include <fstream>

#include "config_support.hpp"
#include "daemon/standcald/config.hpp"
#include "daemon/standcald/hardware.hpp"
#include "daemon_process.hpp"
#include "tests/support/command.hpp"
#include "tests/support/unit_static_recording.hpp"

using namespace standcal::daemon;
using nlohmann::json;
using standcal::test::config_error;

namespace {

// The exit status of a daemon that is expected to give up at start (-1: still running
// after 20 s, or killed by a signal).
int exit_code_at_start(standcal::test::DaemonProcess& d) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (!d.exited() && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  if (!d.exited() || !WIFEXITED(d.wait_status())) return -1;
  return WEXITSTATUS(d.wait_status());
}

}  // namespace

TEST(DaemonConfig, ReadsEveryGroupOfKeys) {
  const json doc = json::parse(R"({
    "socket": {"path": "/tmp/x.sock", "group": "standcal"},
    "tcp": {"enabled": true, "port": 7777},
    "state_dir": "/tmp/state", "max_clients": 300, "log_level": "debug",
    "stand": {"backend": "modbus", "id": "stand-3", "url": "tcp://127.0.0.1:1502?unit=1",
              "outer": {"continuous": true}, "inner": {"min_deg": -170, "max_deg": 170},
              "in_position": {"window_deg": 0.002, "dwell_s": 0.5, "timeout_s": 90}, "home_timeout_s": 100},
    "unit": {"backend": "socketcan", "interface": "can1", "sample_rate_hz": 200,
             "bias_instability_ug": 5, "bias_instability_tau_s": 600},
    "sim": {"time_scale": 10, "seed": 3},
    "run": {"settle_s": 3, "dwell_s": 30, "g_local_mps2": 9.8105, "g_source": "PTB survey 2024",
            "stability": {"sigma_limit_ug": 500, "remeasure_max": 1, "trend_limit_sigmas": 6},
            "thermal_wait": {"enabled": true, "rate_limit_c_per_min": 0.02}},
    "programs": {"library_dir": "/etc/standcal/programs"}
  })");
  const DaemonConfig c = parse_config(doc, "lab.json");
  EXPECT_EQ(c.socket_path, "/tmp/x.sock");
  EXPECT_EQ(c.socket_group, "standcal");
  EXPECT_TRUE(c.tcp_enabled);
  EXPECT_EQ(c.tcp_port, 7777);
  EXPECT_EQ(c.max_clients, 300);
  EXPECT_EQ(c.stand_backend, "modbus");
  EXPECT_TRUE(c.outer.continuous);
  EXPECT_DOUBLE_EQ(c.inner.max_deg, 170);
  EXPECT_DOUBLE_EQ(c.in_position.window_deg, 0.002);
  EXPECT_EQ(c.can_interface, "can1");
  EXPECT_DOUBLE_EQ(c.sample_rate_hz, 200);
  EXPECT_DOUBLE_EQ(c.unit_wander.size_ug, 5);
  EXPECT_DOUBLE_EQ(c.unit_wander.tau_s, 600);
  EXPECT_DOUBLE_EQ(c.g_local_mps2, 9.8105);
  EXPECT_EQ(c.stability.remeasure_max, 1);
  EXPECT_DOUBLE_EQ(c.stability.trend_limit_sigmas, 6);
  EXPECT_TRUE(c.thermal.enabled);
  EXPECT_EQ(c.program_library_dir, "/etc/standcal/programs");
}

// The unit's correlation time: one value, a range up to unit.bias_instability_tau_max_s, or
// nothing (the fits estimate it); a range without its lower end or upside down is refused.
TEST(DaemonConfig, TheUnitsCorrelationTimeIsAValueOrARange) {
  EXPECT_FALSE(parse_config(json::object(), "lab.json").unit_wander.known_tau.has_value());
  const DaemonConfig one =
      parse_config(json{{"unit", {{"bias_instability_tau_s", 400}}}}, "lab.json");
  ASSERT_TRUE(one.unit_wander.known_tau.has_value());
  EXPECT_DOUBLE_EQ(one.unit_wander.known_tau->min_s, 400);
  EXPECT_DOUBLE_EQ(one.unit_wander.known_tau->max_s, 400);
  const DaemonConfig range = parse_config(
      json{{"unit", {{"bias_instability_tau_s", 200}, {"bias_instability_tau_max_s", 700}}}},
      "lab.json");
  ASSERT_TRUE(range.unit_wander.known_tau.has_value());
  EXPECT_DOUBLE_EQ(range.unit_wander.known_tau->min_s, 200);
  EXPECT_DOUBLE_EQ(range.unit_wander.known_tau->max_s, 700);
  EXPECT_EQ(config_error(json{{"unit", {{"bias_instability_tau_max_s", 700}}}}),
            "lab.json: unit.bias_instability_tau_max_s: a range needs its lower end too: "
            "bias_instability_tau_s");
  EXPECT_EQ(config_error(json{
                {"unit", {{"bias_instability_tau_s", 700}, {"bias_instability_tau_max_s", 200}}}}),
            "lab.json: unit.bias_instability_tau_max_s: 200 s is below bias_instability_tau_s "
            "(700 s): the range is MIN to MAX");
}

// unit.static_recording is read and fitted at start: the wander its Allan curves pin is the
// unit's; one whose curves show none gives its curves, and one whose curves see a wander they do
// not pin the floor they put under its correlation time, which the runs' headers carry; beside
// unit.bias_instability_*, or a file that cannot be read, stops the start, naming the key.
TEST(DaemonConfig, TheUnitsStaticRecordingGivesItsWanderAtStart) {
  const std::string pinned = ::testing::TempDir() + "/standcal-static-pinned.csv";
  standcal::write_recording(standcal::test::unit_static_recording(7200, 3, 60, 7), pinned);
  const DaemonConfig c = parse_config(json{{"unit", {{"static_recording", pinned}}}}, "lab.json");
  ASSERT_TRUE(c.unit_static_recording.has_value());
  EXPECT_EQ(c.unit_static_recording->gave, "wander") << c.unit_static_recording->why;
  EXPECT_NEAR(c.unit_wander.size_ug, 3, 1.2);
  ASSERT_TRUE(c.unit_wander.known_tau.has_value());
  EXPECT_LT(c.unit_wander.known_tau->min_s, 60 * 1.5);
  EXPECT_GT(c.unit_wander.known_tau->max_s, 60 / 1.5);
  EXPECT_EQ(
      config_error(json{{"unit", {{"static_recording", pinned}, {"bias_instability_ug", 3}}}}),
      "lab.json: unit.static_recording: give the unit's wander either as a static "
      "recording or as unit.bias_instability_*, not both");
  EXPECT_EQ(config_error(json{{"unit", {{"static_recording", "/nonexistent/still.csv"}}}})
                .rfind("lab.json: unit.static_recording: /nonexistent/still.csv", 0),
            0u)
      << config_error(json{{"unit", {{"static_recording", "/nonexistent/still.csv"}}}});
  const std::string still = ::testing::TempDir() + "/standcal-static-still.csv";
  standcal::write_recording(standcal::test::unit_static_recording(7200, 0, 300, 4), still);
  const DaemonConfig none = parse_config(json{{"unit", {{"static_recording", still}}}}, "lab.json");
  ASSERT_TRUE(none.unit_static_recording.has_value());
  // Its curves bound the wander each run's sigmas allow for: the runs' headers carry them.
  EXPECT_EQ(none.unit_static_recording->gave, "curves") << none.unit_static_recording->why;
  EXPECT_NE(none.unit_static_recording->why.find(
                "show no wander; each run's header carries them (unit_static_allan_curves), and a "
                "fit of the run weighs them as a bound on the wander its sigmas allow for where "
                "the run shows no wander of its own"),
            std::string::npos)
      << none.unit_static_recording->why;
  ASSERT_TRUE(none.unit_static_curves_ug.has_value());
  EXPECT_GT(none.unit_static_curves_ug->curves_end_s, 60);
  EXPECT_FALSE(none.unit_wander.given());
  // A pinned wander carries no curves.
  EXPECT_FALSE(c.unit_static_curves_ug.has_value());
  EXPECT_EQ(c.unit_static_tau_floor_s, 0);
  // Curves that see a wander they do not pin give the floor they put under its correlation
  // time, which the runs' headers carry.
  const std::string slow = ::testing::TempDir() + "/standcal-static-slow.csv";
  standcal::write_recording(
      standcal::test::unit_static_recording(7200, 30, 1200, standcal::test::kSlowWanderStaticSeed),
      slow);
  const DaemonConfig floored =
      parse_config(json{{"unit", {{"static_recording", slow}}}}, "lab.json");
  ASSERT_TRUE(floored.unit_static_recording.has_value());
  EXPECT_EQ(floored.unit_static_recording->gave, "floor") << floored.unit_static_recording->why;
  EXPECT_GT(floored.unit_static_tau_floor_s, 60);
  // The floor the file's own curves put, as `standcal fit --unit-static-recording` reads it.
  EXPECT_DOUBLE_EQ(
      floored.unit_static_tau_floor_s,
      standcal::stand_unit_static_allan(standcal::read_input(slow), floored.g_local_mps2)
          .allan.wander_tau_floor_s);
  EXPECT_FALSE(floored.unit_static_curves_ug.has_value());
  EXPECT_EQ(none.unit_static_tau_floor_s, 0);
  EXPECT_NE(floored.unit_static_recording->why.find(
                "s or longer; each run's header carries that floor (unit_static_tau_floor_s), and "
                "a fit of the run takes it where the run shows the wander at those times"),
            std::string::npos)
      << floored.unit_static_recording->why;
  EXPECT_FALSE(floored.unit_wander.given());
  std::remove(slow.c_str());
  std::remove(pinned.c_str());
  std::remove(still.c_str());
}

// unit.static_recording_input says how the file is read, as --unit-static-* does for the
// offline commands: here the same two hours as headerless x,y,z rows, which need their sample
// rate. Without it the start stops, and the message names the key, not a command-line option.
TEST(DaemonConfig, TheUnitsStaticRecordingIsReadByItsOwnInputKeys) {
  const standcal::Recording still = standcal::test::unit_static_recording(7200, 3, 60, 7);
  const std::string recording = ::testing::TempDir() + "/standcal-static-recording.csv";
  const std::string rows = ::testing::TempDir() + "/standcal-static-rows.csv";
  standcal::write_recording(still, recording);
  {
    std::ofstream out(rows);
    out.precision(17);
    for (const standcal::RecordingSample& r : still.samples)
      out << r.f_mps2[0] << ',' << r.f_mps2[1] << ',' << r.f_mps2[2] << '\n';
  }
  const std::string unread = config_error(json{{"unit", {{"static_recording", rows}}}});
  EXPECT_EQ(unread.rfind("lab.json: unit.static_recording: " + rows, 0), 0u) << unread;
  EXPECT_NE(unread.find("pass unit.static_recording_input.rate_hz with the sample rate"),
            std::string::npos)
      << unread;

  const DaemonConfig from_rows = parse_config(
      json{{"unit", {{"static_recording", rows}, {"static_recording_input", {{"rate_hz", 10}}}}}},
      "lab.json");
  const DaemonConfig from_recording =
      parse_config(json{{"unit", {{"static_recording", recording}}}}, "lab.json");
  ASSERT_TRUE(from_rows.unit_static_recording.has_value());
  EXPECT_EQ(from_rows.unit_static_recording->gave, "wander")
      << from_rows.unit_static_recording->why;
  // The same samples: the same wander, but for the rows' times made from the rate.
  EXPECT_TRUE(
      from_rows.unit_wander.size_axes_ug.isApprox(from_recording.unit_wander.size_axes_ug, 1e-6))
      << from_rows.unit_wander.size_axes_ug - from_recording.unit_wander.size_axes_ug;
  // No g of its own (run.g_local_mps2 puts it in ug), so no "assuming standard gravity".
  EXPECT_TRUE(from_rows.unit_static_recording->warnings.empty())
      << from_rows.unit_static_recording->warnings.front();

  EXPECT_EQ(config_error(json{{"unit", {{"static_recording_input", {{"rate_hz", 10}}}}}}),
            "lab.json: unit.static_recording_input: says how unit.static_recording is read: "
            "give it too");
  EXPECT_NE(
      config_error(json{{"unit",
                         {{"static_recording", rows},
                          {"static_recording_input", {{"rate_hz", 10}, {"colums", "1,2,3"}}}}}})
          .find("unit.static_recording_input.colums"),
      std::string::npos);
  std::remove(recording.c_str());
  std::remove(rows.c_str());
}

// run.budget is read at start: a bad file stops the daemon's start, naming the key.
TEST(DaemonConfig, TheBudgetFileIsReadAtStart) {
  const std::string path = ::testing::TempDir() + "/standcal-budget-test.json";
  std::ofstream(path)
      << R"({"format": "standcal-budget/1", "gravity": {"standard_uncertainty_mps2": 2e-5}})";
  const DaemonConfig c = parse_config(json{{"run", {{"budget", path}}}}, "lab.json");
  ASSERT_TRUE(c.budget.has_value());
  EXPECT_DOUBLE_EQ(c.budget->g_standard_uncertainty_mps2, 2e-5);
  std::ofstream(path) << R"({"format": "standcal-budget/1", "stand": {"level": 3}})";
  EXPECT_EQ(config_error(json{{"run", {{"budget", path}}}}),
            "lab.json: run.budget: " + path + ": stand.level: unknown key");
  std::remove(path.c_str());
}

// A register map whose timing lets lost replies outlast the controller's watchdog, or whose
// watchdog is off, is used, and said: the daemon logs the hardware's warnings at start, each
// naming the files.
TEST(DaemonConfig, AStandTimingWhoseRetriesOutlastItsWatchdogIsSaid) {
  const std::string path = ::testing::TempDir() + "/standcal-stand-map-test.json";
  std::ofstream(path) << R"({"timing": {"heartbeat_timeout_s": 0.5}})";
  const DaemonConfig c = parse_config(
      json{{"stand", {{"backend", "modbus"}, {"url", "tcp://127.0.0.1:1"}, {"register_map", path}}},
           {"unit", {{"backend", "sim"}}}},
      "lab.json");
  const Hardware hw = make_hardware(c);  // opens no link until the stand is configured
  ASSERT_EQ(hw.warnings.size(), 1u);
  EXPECT_EQ(hw.warnings[0].rfind("lab.json: stand.register_map: " + path +
                                     ": timing: a request retried 3 times at timeout_s 0.3 s",
                                 0),
            0u)
      << hw.warnings[0];
  // A watchdog switched off leaves a stand moving when the daemon dies: said too.
  std::ofstream(path) << R"({"timing": {"heartbeat_timeout_s": 0}})";
  const Hardware off = make_hardware(c);
  ASSERT_EQ(off.warnings.size(), 1u);
  EXPECT_NE(off.warnings[0].find(path + ": timing: heartbeat_timeout_s 0 switches the "
                                        "controller's heartbeat watchdog off"),
            std::string::npos)
      << off.warnings[0];
  std::remove(path.c_str());
}

TEST(DaemonConfig, ErrorsNameTheKeyAndTheReason) {
  EXPECT_EQ(config_error(json{{"run", {{"dwell_s", "long"}}}}),
            "lab.json: run.dwell_s: must be a number");
  EXPECT_NE(
      config_error(json{{"stand", {{"backend", "canopen"}}}}).find("stand.backend: must be one of"),
      std::string::npos);
  EXPECT_NE(config_error(json{{"stand", {{"inner", {{"max_dg", 10}}}}}})
                .find("stand.inner.max_dg: unknown key"),
            std::string::npos);
  EXPECT_NE(config_error(json{{"max_clients", 10}}).find("max_clients: must be between 256"),
            std::string::npos);
  EXPECT_NE(config_error(json{{"stand", {{"backend", "modbus"}}}}).find("stand.url: is required"),
            std::string::npos);
  EXPECT_NE(config_error(json{{"run", {{"g_local_mps2", 98.1}}}}).find("run.g_local_mps2"),
            std::string::npos);
  // A dwell is judged whole, so held whole: a default dwell of more samples than that is
  // refused when the daemon starts, not at each run.start.
  EXPECT_EQ(config_error(json{{"run", {{"dwell_s", 36000}}}, {"unit", {{"sample_rate_hz", 2000}}}}),
            "lab.json: run.dwell_s: 36000 s at unit.sample_rate_hz 2000 Hz would be 72000000 "
            "samples a dwell, more than the 4000000 a dwell holds at once to be judged: at most "
            "2000 s");
  // stand.id goes into every recording header: one printable line.
  EXPECT_EQ(config_error(json{{"stand", {{"id", "bench-1\n# mount: y"}}}}),
            "lab.json: stand.id: must be printable text on one line: it contains the control "
            "character U+000A at "
            "character 8");
}

TEST(DaemonConfig, TheConfigHashFollowsTheContent) {
  const DaemonConfig a = parse_config(json{{"run", {{"dwell_s", 30}}}}, "a");
  const DaemonConfig b = parse_config(json{{"run", {{"dwell_s", 31}}}}, "b");
  EXPECT_EQ(config_hash(a), config_hash(parse_config(json{{"run", {{"dwell_s", 30}}}}, "c")));
  EXPECT_NE(config_hash(a), config_hash(b));
}

TEST(DaemonProcessStart, ABadConfigFailsAtStartNamingTheKey) {
  standcal::test::TempDir dir;
  const std::string file = dir.path() + "/bad.json";
  std::ofstream(file) << R"({"state_dir": ")" << dir.path()
                      << R"(/state", "run": {"settle_s": -4}})";
  standcal::test::DaemonProcess d(dir.path(), {"--config", file});
  EXPECT_EQ(exit_code_at_start(d), 1);
  EXPECT_NE(d.log().find("run.settle_s: must be between 0 and 3600"), std::string::npos) << d.log();
}

// `--config DIR` used to say only "basic_filebuf::underflow", naming no file.
TEST(DaemonProcessStart, AConfigThatIsADirectoryIsNamedAsOne) {
  standcal::test::TempDir dir;
  standcal::test::DaemonProcess d(dir.path(), {"--config", dir.path()});
  EXPECT_EQ(exit_code_at_start(d), 1);
  EXPECT_NE(d.log().find("standcald: " + dir.path() + ": is a directory, not a config file"),
            std::string::npos)
      << d.log();
  EXPECT_EQ(d.log().find("underflow"), std::string::npos) << d.log();
  // The CLI reads the socket path from the same file.
  const auto cli = standcal::test::standcal_cli("status --config " + dir.path());
  EXPECT_EQ(cli.exit_code, 1) << cli.output;
  EXPECT_NE(cli.output.find("--config " + dir.path() + ": is a directory"), std::string::npos)
      << cli.output;
}

TEST(DaemonConfig, ClientTimeoutsAreReadAndChecked) {
  const DaemonConfig c = parse_config(
      json{{"client_request_timeout_s", 2.5}, {"client_idle_timeout_s", 60}}, "lab.json");
  EXPECT_DOUBLE_EQ(c.client_request_timeout_s, 2.5);
  EXPECT_DOUBLE_EQ(c.client_idle_timeout_s, 60);
  const DaemonConfig d = parse_config(json::object(), "lab.json");
  EXPECT_DOUBLE_EQ(d.client_request_timeout_s, 10);
  EXPECT_DOUBLE_EQ(d.client_idle_timeout_s, 600);
  EXPECT_NE(standcal::test::config_error(json{{"client_request_timeout_s", 0}})
                .find("client_request_timeout_s: must be between"),
            std::string::npos);
}

// A lab config that lost its "stand" (or "unit") section must not calibrate a simulated
// stand: the daemon refuses to start and says how to simulate on purpose (issue 19).
TEST(DaemonProcessStart, AConfigWithoutBackendsIsRefusedUnlessSimulationIsAskedFor) {
  standcal::test::TempDir dir;
  const std::string file = dir.path() + "/lab.json";
  std::ofstream(file) << json{{"socket", {{"path", dir.path() + "/standcald.sock"}}},
                              {"state_dir", dir.path() + "/state"},
                              {"unit", {{"backend", "socketcan"}}}}
                             .dump();
  standcal::test::DaemonProcess refused(dir.path(), {"--config", file});
  EXPECT_EQ(exit_code_at_start(refused), 1);
  EXPECT_NE(refused.log().find(file + ": stand.backend: not given"), std::string::npos)
      << refused.log();
  EXPECT_NE(refused.log().find("--sim"), std::string::npos) << refused.log();

  // Asked for in the file: it runs, and `status` says the stand is simulated.
  std::ofstream(file) << json{
      {"socket", {{"path", dir.path() + "/standcald.sock"}}},
      {"state_dir", dir.path() + "/state"},
      {"stand", {{"backend", "sim"}}},
      {"unit",
       {{"backend", "sim"}}}}.dump();
  standcal::test::DaemonProcess simulated(dir.path(), {"--config", file});
  simulated.wait_ready(dir.path() + "/standcald.sock");
  standcal::protocol::Client c(dir.path() + "/standcald.sock");
  const json backend = c.call("status")["backend"];
  EXPECT_EQ(backend["stand"], "sim");
  EXPECT_EQ(backend["simulated"], true);
  const auto cli =
      standcal::test::standcal_cli("status --socket " + dir.path() + "/standcald.sock");
  EXPECT_NE(cli.output.find("SIMULATED"), std::string::npos) << cli.output;
}

TEST(DaemonConfig, BackendsAreNamedOnlyWhenGiven) {
  EXPECT_FALSE(parse_config(json::object(), "lab.json").stand_backend_named);
  const DaemonConfig c = parse_config(
      json{{"stand", {{"backend", "sim"}}}, {"unit", {{"backend", "sim"}}}}, "lab.json");
  EXPECT_TRUE(c.stand_backend_named && c.unit_backend_named);
  EXPECT_NO_THROW(require_named_backends(c));
  EXPECT_THROW(require_named_backends(parse_config(json{{"stand", {{"id", "x"}}}}, "lab.json")),
               ConfigError);
}
