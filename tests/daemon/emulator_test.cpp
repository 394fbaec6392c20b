// standcald on the real hardware backends against the emulators: the Modbus stand driver
// talking to standcal-stand-emu over TCP on loopback, and the SocketCAN unit reading
// standcal-can-emu's CAN frames through a SOCK_SEQPACKET socketpair (this kernel has no
// CAN; the unit backend takes an inherited fd as `unit.interface: "fd:N"`).
//
// The CAN emulator sends a unit at fixed angles (it does not follow the stand), so this
// test checks the run mechanics — moves reached, samples recorded, every position once,
// a result stored — not the calibration values (the sim-backend tests check those).
#include <gtest/gtest.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <thread>

#include "calib/recording.hpp"
#include "daemon_process.hpp"
#include "tests/support/command.hpp"

using namespace standcal;
using namespace std::chrono_literals;
using nlohmann::json;
using protocol::Client;
using test::DaemonProcess;
using test::TempDir;

namespace {

std::string wait_for_line(const std::string& path, std::chrono::seconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < deadline) {
    std::ifstream in(path);
    std::string line;
    if (std::getline(in, line) && !line.empty() && !in.eof()) return line;
    std::this_thread::sleep_for(20ms);
  }
  return "";
}

// standcald on the stand emulator (Modbus TCP, `emu_args` added) and the simulated unit,
// its stand enabled and homed, then moving towards alpha1 = 170 deg (no wait) until the
// outer axis has passed `past_deg`: a stop from there takes the drives time to decelerate.
struct StandEmulatorDaemon {
  std::unique_ptr<DaemonProcess> emulator, daemon;
};

StandEmulatorDaemon moving_stand_emulator(const TempDir& dir, std::vector<std::string> emu_args,
                                          double past_deg) {
  StandEmulatorDaemon d;
  emu_args.insert(emu_args.begin(), {"--listen", "tcp://127.0.0.1:0"});
  d.emulator =
      std::make_unique<DaemonProcess>(dir.path(), emu_args, std::vector<std::string>{},
                                      STANDCAL_STAND_EMU_PATH, "stand-emu.log", "stand-emu.out");
  const std::string url = wait_for_line(dir.path() + "/stand-emu.out", 20s);
  if (url.empty())
    throw std::runtime_error("the stand emulator printed no URL:\n" + d.emulator->log());
  const json config{{"socket", {{"path", dir.path() + "/standcald.sock"}}},
                    {"state_dir", dir.path() + "/state"},
                    {"stand", {{"backend", "modbus"}, {"url", url}}},
                    {"unit", {{"backend", "sim"}}}};
  std::ofstream(dir.path() + "/standcald.json") << config.dump(2);
  d.daemon = std::make_unique<DaemonProcess>(
      dir.path(), std::vector<std::string>{"--config", dir.path() + "/standcald.json"});
  d.daemon->wait_ready(dir.path() + "/standcald.sock");
  Client c(dir.path() + "/standcald.sock");
  c.call("stand.enable");
  c.call("stand.home", json::object(), 60s);
  c.call("stand.move", {{"alpha1_deg", 170}, {"alpha2_deg", 0}, {"wait", false}});
  const auto deadline = std::chrono::steady_clock::now() + 30s;
  while (c.call("status")["stand"]["axes"][0].value("angle_deg", 0.0) < past_deg) {
    if (std::chrono::steady_clock::now() > deadline)
      throw std::runtime_error("the outer axis did not pass " + std::to_string(past_deg) +
                               " deg:\n" + d.daemon->log());
    std::this_thread::sleep_for(50ms);
  }
  return d;
}

}  // namespace

TEST(DaemonEmulators, Paper9RunOnTheModbusStandAndCanUnitEmulators) {
  TempDir dir;
  int pair[2];
  ASSERT_EQ(::socketpair(AF_UNIX, SOCK_SEQPACKET, 0, pair), 0);  // inherited by both children

  DaemonProcess stand_emu(dir.path(), {"--listen", "tcp://127.0.0.1:0", "--time-scale", "50"}, {},
                          STANDCAL_STAND_EMU_PATH, "stand-emu.log", "stand-emu.out");
  const std::string url = wait_for_line(dir.path() + "/stand-emu.out", 20s);
  ASSERT_FALSE(url.empty()) << stand_emu.log();
  DaemonProcess can_emu(dir.path(), {"--fd", std::to_string(pair[0]), "--rate-hz", "100"}, {},
                        STANDCAL_CAN_EMU_PATH, "can-emu.log");

  const json config{
      {"socket", {{"path", dir.path() + "/standcald.sock"}}},
      {"state_dir", dir.path() + "/state"},
      {"stand", {{"backend", "modbus"}, {"url", url}, {"id", "emu-stand"}}},
      {"unit", {{"backend", "socketcan"}, {"interface", "fd:" + std::to_string(pair[1])}}},
      {"run", {{"settle_s", 0.1}, {"dwell_s", 1}}}};
  std::ofstream(dir.path() + "/standcald.json") << config.dump(2);
  DaemonProcess daemon(dir.path(), {"--config", dir.path() + "/standcald.json"});
  ::close(pair[0]);
  ::close(pair[1]);
  daemon.wait_ready(dir.path() + "/standcald.sock");

  Client c(dir.path() + "/standcald.sock");
  const std::string run_id =
      c.call("run.start", {{"program", "paper9"}, {"unit_serial", "AU-EMU"}})["run_id"];
  json s;
  const auto deadline = std::chrono::steady_clock::now() + 120s;
  while (std::chrono::steady_clock::now() < deadline) {
    s = c.call("run.status", {{"run_id", run_id}});
    if (s["state"] != "running") break;
    std::this_thread::sleep_for(100ms);
  }
  ASSERT_EQ(s["state"], "done") << s.dump() << daemon.log();

  const Recording rec = read_recording(s["recording_path"]);
  std::map<int, std::size_t> blocks;
  for (const RecordingSample& x : rec.samples) {
    ++blocks[x.pos];
    // The stand's angle sensors read the commanded angle (encoder noise only).
    ASSERT_NEAR(x.alpha1_deg, x.alpha1_cmd_deg, 0.01) << "position " << x.pos;
    ASSERT_NEAR(x.alpha2_deg, x.alpha2_cmd_deg, 0.01) << "position " << x.pos;
  }
  ASSERT_EQ(blocks.size(), 9u);
  for (const auto& [pos, n] : blocks) EXPECT_GE(n, 90u) << "position " << pos;  // 1 s at 100 Hz
  const json result = c.call("run.result", {{"run_id", run_id}});
  EXPECT_EQ(result["positions"], 9);
  EXPECT_EQ(result["traceability"]["stand_id"], "emu-stand");
}

// The emulator's drives decelerate at their acceleration limit, so a stop takes time:
// stand.stop answers once the controller itself (its own registers, written to the
// status file) says neither axis moves any more.
TEST(DaemonEmulators, StandStopAnswersOnceTheEmulatorsAxesHaveStopped) {
  TempDir dir;
  // Up to speed (10 °/s² for 2 s: 20 °/s, 2 s to stop again) before the stop.
  const StandEmulatorDaemon stand = moving_stand_emulator(
      dir, {"--accel-dps2", "10", "--status-file", dir.path() + "/stand-status"}, 20.0);
  Client c(dir.path() + "/standcald.sock");
  EXPECT_EQ(c.call("stand.stop")["stopped"], true);
  // The first status file the emulator writes after the answer: "NAME STATE FLAGS ANGLE FAULT".
  const auto answered = std::filesystem::file_time_type::clock::now();
  for (int wait = 0;
       wait < 500 && std::filesystem::last_write_time(dir.path() + "/stand-status") <= answered;
       ++wait) {
    std::this_thread::sleep_for(10ms);  // rewritten every 50 ms
  }
  std::ifstream status(dir.path() + "/stand-status");
  std::string name;
  int state = -1;
  std::string rest;
  int axes = 0;
  while (status >> name >> state && std::getline(status, rest)) {
    ++axes;
    EXPECT_TRUE(state != 2 && state != 3)
        << name << " axis still homing (2) or moving (3): " << state;
  }
  EXPECT_EQ(axes, 2);
}

// While stand.stop waits for the drives to decelerate (up to in_position.timeout_s, 120 s
// by default: a stuck axis keeps it waiting), an emergency stop sent after it is served at
// once, not after the wait: both in one write, the estop's answer comes first.
TEST(DaemonEmulators, AnEstopIsNotHeldBackByAStandStopWaitingForTheAxes) {
  TempDir dir;
  // At 2 deg/s^2, 16 deg is reached at 8 deg/s, and stopping from there takes 4 s.
  const StandEmulatorDaemon stand = moving_stand_emulator(dir, {"--accel-dps2", "2"}, 16.0);
  Client c(dir.path() + "/standcald.sock");
  c.send_raw(json{{"jsonrpc", "2.0"}, {"id", 1}, {"method", "stand.stop"}}.dump() + "\n" +
             json{{"jsonrpc", "2.0"}, {"id", 2}, {"method", "estop"}}.dump() + "\n");
  std::vector<json> answers;
  const auto answer_deadline = std::chrono::steady_clock::now() + 60s;
  while (answers.size() < 2 && std::chrono::steady_clock::now() < answer_deadline) {
    auto m = c.next_message(1s);
    if (m && m->contains("id")) answers.push_back(*m);
  }
  ASSERT_EQ(answers.size(), 2u) << stand.daemon->log();
  EXPECT_EQ(answers[0]["id"], 2) << "the estop waited for stand.stop: " << answers[0].dump();
  EXPECT_EQ(answers[0]["result"]["estop"], true) << answers[0].dump();
  EXPECT_EQ(answers[1]["id"], 1) << answers[1].dump();
}

namespace {

// `standcal doctor --json` with the checks by name.
std::map<std::string, json> doctor_checks(const std::string& config, int* exit_code) {
  const auto r = test::run_command(std::string(STANDCAL_CLI_PATH) + " doctor --json --config " +
                                   config + " 2>/dev/null");
  *exit_code = r.exit_code;
  std::map<std::string, json> checks;
  for (const json& line : json::parse(r.output)) checks[line["check"].get<std::string>()] = line;
  return checks;
}

}  // namespace

// `standcal doctor` with the daemon stopped opens the stand and the unit as the daemon would:
// against the emulators the link and the unit's rate pass; with the stand emulator stopped
// the stand link fails and says what to check (issue 19).
TEST(Doctor, ChecksTheStandAndTheUnitOfTheEmulatorsAndNamesAStoppedOne) {
  TempDir dir;
  int pair[2];
  ASSERT_EQ(::socketpair(AF_UNIX, SOCK_SEQPACKET, 0, pair),
            0);  // inherited by the emulator and doctor
  auto stand_emu = std::make_unique<DaemonProcess>(
      dir.path(), std::vector<std::string>{"--listen", "tcp://127.0.0.1:0"},
      std::vector<std::string>{}, STANDCAL_STAND_EMU_PATH, "stand-emu.log", "stand-emu.out");
  const std::string url = wait_for_line(dir.path() + "/stand-emu.out", 20s);
  ASSERT_FALSE(url.empty()) << stand_emu->log();
  DaemonProcess can_emu(dir.path(), {"--fd", std::to_string(pair[0]), "--rate-hz", "100"}, {},
                        STANDCAL_CAN_EMU_PATH, "can-emu.log");
  std::filesystem::create_directories(dir.path() + "/state");
  const std::string config = dir.path() + "/standcald.json";
  std::ofstream(config)
      << json{{"socket", {{"path", dir.path() + "/standcald.sock"}}},
              {"state_dir", dir.path() + "/state"},
              {"stand", {{"backend", "modbus"}, {"url", url}}},
              {"unit", {{"backend", "socketcan"}, {"interface", "fd:" + std::to_string(pair[1])}}}}
             .dump();
  int exit_code = 0;
  auto checks = doctor_checks(config, &exit_code);
  EXPECT_EQ(checks["config"]["verdict"], "PASS") << checks["config"];
  EXPECT_EQ(checks["state directory"]["verdict"], "PASS") << checks["state directory"];
  EXPECT_EQ(checks["daemon"]["verdict"], "FAIL") << "no daemon was started";
  EXPECT_EQ(checks["stand timing"]["verdict"], "PASS") << checks["stand timing"];
  EXPECT_NE(checks["stand timing"]["detail"].get<std::string>().find(
                "holds the heartbeat for at most 1 s, within the 1 s watchdog"),
            std::string::npos)
      << checks["stand timing"];
  EXPECT_EQ(checks["stand link"]["verdict"], "PASS") << checks["stand link"];
  EXPECT_EQ(checks["unit"]["verdict"], "PASS") << checks["unit"];
  EXPECT_EQ(checks["records database"]["verdict"], "PASS") << checks["records database"];
  EXPECT_EQ(exit_code, 1) << "a failed check (the daemon) fails the doctor";

  stand_emu.reset();  // SIGKILL: the controller is gone
  checks = doctor_checks(config, &exit_code);
  EXPECT_EQ(checks["stand link"]["verdict"], "FAIL") << checks["stand link"];
  EXPECT_NE(checks["stand link"]["fix"].get<std::string>().find("stand.url"), std::string::npos);
  EXPECT_EQ(checks["unit"]["verdict"], "PASS") << checks["unit"];
  EXPECT_EQ(exit_code, 1);
  ::close(pair[0]);
  ::close(pair[1]);
}

// A register map whose timing lets lost replies outlast the controller's watchdog, or whose
// watchdog is off, is a WARN of its own (the stand and the daemon are judged as before); one
// that does not parse fails before the daemon's start would.
TEST(Doctor, WarnsOfAStandTimingThatOutlastsOrSwitchesOffTheWatchdog) {
  TempDir dir;
  const std::string config = dir.path() + "/standcald.json";
  const auto doctor_on_map = [&](const std::string& map_text, int* exit_code) {
    dir.write("stand-map.json", map_text);
    std::ofstream(config) << json{
        {"socket", {{"path", dir.path() + "/standcald.sock"}}},
        {"state_dir", dir.path()},
        {"stand",
         {{"backend", "modbus"},
          {"url", "tcp://127.0.0.1:1"},
          {"register_map", dir.file("stand-map.json")}}},
        {"unit",
         {{"backend", "sim"}}}}.dump();
    return doctor_checks(config, exit_code)["stand timing"];
  };
  int exit_code = 0;
  const json outlasting = doctor_on_map(R"({"timing": {"heartbeat_timeout_s": 0.5}})", &exit_code);
  EXPECT_EQ(outlasting["verdict"], "WARN") << outlasting;
  EXPECT_EQ(outlasting["detail"].get<std::string>().rfind(
                config + ": stand.register_map: " + dir.file("stand-map.json") +
                    ": timing: a request retried 3 times at timeout_s 0.3 s, after a "
                    "heartbeat_period_s of 0.1 s, holds the heartbeat for up to 1 s, longer than "
                    "heartbeat_timeout_s 0.5 s",
                0),
            0u)
      << outlasting;
  const json off = doctor_on_map(R"({"timing": {"heartbeat_timeout_s": 0}})", &exit_code);
  EXPECT_EQ(off["verdict"], "WARN") << off;
  EXPECT_NE(off["detail"].get<std::string>().find(
                "heartbeat_timeout_s 0 switches the controller's heartbeat watchdog off"),
            std::string::npos)
      << off;
  const json broken = doctor_on_map(R"({"timing": {"tries": 0}})", &exit_code);
  EXPECT_EQ(broken["verdict"], "FAIL") << broken;
  EXPECT_NE(broken["detail"].get<std::string>().find("tries must be a whole number 1..1000"),
            std::string::npos)
      << broken;
  EXPECT_EQ(exit_code, 1);
}

// With the daemon running, doctor asks it instead of opening the hardware it owns.
TEST(Doctor, AsksARunningDaemon) {
  TempDir dir;
  const std::string config = dir.path() + "/standcald.json";
  std::ofstream(config) << json{
      {"socket", {{"path", dir.path() + "/standcald.sock"}}},
      {"state_dir", dir.path() + "/state"},
      {"stand", {{"backend", "sim"}}},
      {"unit",
       {{"backend", "sim"}}}}.dump();
  DaemonProcess daemon(dir.path(), {"--config", config});
  daemon.wait_ready(dir.path() + "/standcald.sock");
  int exit_code = 0;
  auto checks = doctor_checks(config, &exit_code);
  EXPECT_EQ(checks["daemon"]["verdict"], "PASS") << checks["daemon"];
  EXPECT_NE(checks["daemon"]["detail"].get<std::string>().find("may command the stand"),
            std::string::npos);
  EXPECT_EQ(checks["stand link"]["verdict"], "SKIP")
      << checks["stand link"] << " (the idle daemon's stand is unconfigured)";
  EXPECT_EQ(exit_code, 0) << checks["unit"];

  // A lab config whose daemon was started with --sim: the bench is not what the file says.
  const std::string lab = dir.path() + "/lab.json";
  std::ofstream(lab) << json{{"socket", {{"path", dir.path() + "/standcald.sock"}}},
                             {"state_dir", dir.path() + "/state"},
                             {"stand",
                              {{"backend", "modbus"}, {"url", "tcp://127.0.0.1:1?unit=1"}}},
                             {"unit", {{"backend", "socketcan"}, {"interface", "can0"}}}}
                            .dump();
  checks = doctor_checks(lab, &exit_code);
  EXPECT_EQ(checks["daemon"]["verdict"], "FAIL") << checks["daemon"];
  EXPECT_NE(checks["daemon"]["detail"].get<std::string>().find("drives sim"), std::string::npos)
      << checks["daemon"];
  EXPECT_EQ(exit_code, 1);
}

// A socket that exists but does not answer (a busy daemon, or one this user may not
// reach): doctor must not open the stand and the unit the daemon may be holding.
TEST(Doctor, DoesNotOpenTheHardwareBehindASocketThatDoesNotAnswer) {
  TempDir dir;
  const std::string socket_path = dir.path() + "/standcald.sock";
  const int listener = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  ASSERT_GE(listener, 0);
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  std::snprintf(addr.sun_path, sizeof addr.sun_path, "%s", socket_path.c_str());
  ASSERT_EQ(::bind(listener, reinterpret_cast<const sockaddr*>(&addr), sizeof addr), 0);
  ASSERT_EQ(::listen(listener, 4), 0);  // connections queue, nobody greets them
  const std::string config = dir.path() + "/standcald.json";
  std::ofstream(config) << json{{"socket", {{"path", socket_path}}},
                                {"state_dir", dir.path()},
                                {"stand",
                                 {{"backend", "modbus"}, {"url", "tcp://127.0.0.1:1?unit=1"}}},
                                {"unit", {{"backend", "socketcan"}, {"interface", "can0"}}}}
                               .dump();
  int exit_code = 0;
  auto checks = doctor_checks(config, &exit_code);
  ::close(listener);
  EXPECT_EQ(checks["daemon"]["verdict"], "FAIL") << checks["daemon"];
  EXPECT_EQ(checks["stand link"]["verdict"], "SKIP") << checks["stand link"];
  EXPECT_EQ(checks["unit"]["verdict"], "SKIP") << checks["unit"];
}
