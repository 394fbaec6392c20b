// Text fields of run.start (unit_serial, unit_type, operator, a programme's name) end up
// in the recording header, run.json and the records database: each must be printable
// text on one line, its length counted in characters (UTF-8 code points). A bad one is
// refused at the protocol boundary, naming the field, and no run is created.
#include <gtest/gtest.h>

#include <fstream>

#include "calib/recording.hpp"
#include "daemon_process.hpp"

using namespace standcal;
using namespace std::chrono_literals;
using nlohmann::json;
using protocol::Client;
using protocol::RpcError;
using test::DaemonProcess;
using test::finished;
using test::refusal_of;
using test::socket_of;
using test::TempDir;
using test::wait_run;

namespace {

json paper9_start(const std::string& serial) {
  return json{{"program", "paper9"}, {"unit_serial", serial}, {"dwell_s", 5}, {"settle_s", 0}};
}

std::string repeat(const std::string& piece, int times) {
  std::string out;
  for (int i = 0; i < times; ++i) out += piece;
  return out;
}

}  // namespace

TEST(DaemonTextFields, AControlCharacterInAnyTextFieldIsRefusedNamingTheField) {
  TempDir dir;
  auto daemon = DaemonProcess::sim(dir.path(), 300);
  Client c(socket_of(dir));
  const std::string injected = "AU\n# mount: y";

  json serial = paper9_start(injected);
  json type = paper9_start("AU-1");
  type["unit_type"] = injected;
  json op = paper9_start("AU-1");
  op["operator"] = std::string("A. N. Other\r\n# g_local_mps2: 1");
  json name = paper9_start("AU-1");
  name["program"] = json{{"name", injected},
                         {"positions", json::array({{{"alpha1_deg", 0}, {"alpha2_deg", 0}}})}};
  json nul = paper9_start(std::string("AU\0-1", 5));

  const std::pair<const char*, json> cases[] = {{"unit_serial", serial},
                                                {"unit_type", type},
                                                {"operator", op},
                                                {"name", name},
                                                {"unit_serial", nul}};
  for (const auto& [field, params] : cases) {
    const RpcError e = refusal_of(c, "run.start", params);
    EXPECT_EQ(e.code(), -32602) << field << ": " << e.what();
    const std::string message = e.what();
    EXPECT_NE(message.find(field), std::string::npos) << message;
    EXPECT_NE(message.find("control character"), std::string::npos) << message;
  }
  // Nothing was started, so nothing reached a recording or the records database.
  EXPECT_TRUE(c.call("runs.list")["runs"].empty());
}

TEST(DaemonTextFields, LengthsAreCountedInCharactersNotBytes) {
  TempDir dir;
  auto daemon = DaemonProcess::sim(dir.path(), 300);
  Client c(socket_of(dir));
  // 64 characters, 256 bytes: inside the documented "1–64 characters" (and its run
  // directory's name stays short: one character per character).
  const std::string serial = repeat("\xF0\x90\x8D\x88", 64);  // U+10348, 4 bytes in UTF-8
  json params = paper9_start(serial);
  params["program"] = json::array({{{"alpha1_deg", 0}, {"alpha2_deg", 0}}});
  const std::string run_id = c.call("run.start", params)["run_id"];
  const json s = wait_run(c, run_id, finished);
  EXPECT_EQ(read_recording(s["recording_path"]).unit_serial, serial);

  const RpcError e = refusal_of(c, "run.start", paper9_start(serial + "\xC3\xA9"));  // + é
  EXPECT_EQ(e.code(), -32602);
  EXPECT_NE(std::string(e.what()).find("unit_serial"), std::string::npos) << e.what();
  EXPECT_NE(std::string(e.what()).find("64 characters"), std::string::npos) << e.what();
  // A C1 control (U+0085, next line) is a control character too, though it is valid UTF-8.
  const RpcError c1 = refusal_of(c, "run.start", paper9_start("AU-\xC2\x85-1"));
  EXPECT_EQ(c1.code(), -32602);
  EXPECT_NE(std::string(c1.what()).find("U+0085"), std::string::npos) << c1.what();
}

// The recording header keeps the run's numbers exactly: standcald wrote them to ten
// significant digits, so a g of 9.8162538712345 m/s^2 (as a gravimeter survey plus a tidal
// correction gives it) reached the recording, and every later fit of it (`standcal fit`,
// `import`), as 9.816253871: not the g the daemon's own fit used.
TEST(DaemonTextFields, TheRecordingHeaderKeepsTheRunsNumbersExactly) {
  TempDir dir;
  const std::string config = dir.path() + "/standcald.json";
  std::ofstream(config) << json{{"socket", {{"path", socket_of(dir)}}},
                                {"state_dir", dir.path() + "/state"},
                                {"unit", {{"sample_rate_hz", 100.00000012345}}},
                                {"run", {{"g_local_mps2", 9.8162538712345}}}}
                               .dump();
  DaemonProcess daemon(dir.path(), {"--config", config, "--sim", "--time-scale", "300"});
  daemon.wait_ready(socket_of(dir));
  Client c(socket_of(dir));
  json params = paper9_start("AU-0042");
  params["program"] = json::array({{{"alpha1_deg", 0}, {"alpha2_deg", 0}}});
  params["settle_s"] = 0.12345678912345;
  const std::string run_id = c.call("run.start", params)["run_id"];
  const Recording rec = read_recording(wait_run(c, run_id, finished)["recording_path"]);
  EXPECT_EQ(rec.g_local_mps2, 9.8162538712345);
  EXPECT_EQ(rec.header_value("g_local_mps2"), "9.8162538712345");
  EXPECT_EQ(rec.settle_s, 0.12345678912345);
  EXPECT_EQ(rec.sample_rate_hz, 100.00000012345);
}
