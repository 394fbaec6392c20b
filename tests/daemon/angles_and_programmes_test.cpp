// Numbers and keys a client sends for motion: a huge angle goes to its exact equivalent
// (1e308° ≡ −64°), a position's dwell or settle past the run limits and an unknown key
// in a programme are refused naming the position, the limit or the key.
#include <gtest/gtest.h>

#include <cmath>

#include "daemon_process.hpp"

using namespace standcal;
using namespace std::chrono_literals;
using nlohmann::json;
using protocol::Client;
using protocol::RpcError;
using test::DaemonProcess;
using test::socket_of;
using test::TempDir;

namespace {

// The message of a call that must fail with `code`.
std::string refusal(Client& c, const std::string& method, const json& params, int code) {
  try {
    const json r = c.call(method, params);
    ADD_FAILURE() << method << " accepted " << params.dump() << ": " << r.dump();
  } catch (const RpcError& e) {
    EXPECT_EQ(e.code(), code) << e.what();
    return e.what();
  }
  return {};
}

json one_position(json position) {
  return json{{"program", json::array({std::move(position)})}, {"unit_serial", "AU-9"}};
}

}  // namespace

TEST(DaemonAngles, AHugeAngleMovesToItsExactEquivalent) {
  TempDir dir;
  auto daemon = DaemonProcess::sim(dir.path(), 100);
  Client c(socket_of(dir));
  c.call("stand.enable");
  c.call("stand.home", json::object(), 60s);
  const double equivalent_deg = std::remainder(1e308, 360.0);
  ASSERT_NEAR(equivalent_deg, -64.0, 1e-9);
  const json moved = c.call("stand.move", {{"alpha1_deg", 1e308}, {"alpha2_deg", -1e308}}, 60s);
  EXPECT_NEAR(moved["alpha1_deg"].get<double>(), equivalent_deg, 0.01) << moved.dump();
  EXPECT_NEAR(moved["alpha2_deg"].get<double>(), -equivalent_deg, 0.01) << moved.dump();
}

TEST(DaemonProgrammes, APositionsDwellOrSettlePastTheRunLimitIsRefused) {
  TempDir dir;
  auto daemon = DaemonProcess::sim(dir.path(), 100);
  Client c(socket_of(dir));
  std::string m =
      refusal(c, "run.start",
              one_position({{"alpha1_deg", 0}, {"alpha2_deg", 0}, {"dwell_s", 1e9}}), -32602);
  EXPECT_NE(m.find("position 1"), std::string::npos) << m;
  EXPECT_NE(m.find("dwell_s"), std::string::npos) << m;
  EXPECT_NE(m.find("36000"), std::string::npos) << m;
  m = refusal(c, "run.start",
              one_position({{"alpha1_deg", 0}, {"alpha2_deg", 0}, {"settle_s", 1e9}}), -32602);
  EXPECT_NE(m.find("settle_s"), std::string::npos) << m;
  EXPECT_NE(m.find("3600"), std::string::npos) << m;
  EXPECT_TRUE(c.call("runs.list")["runs"].empty());
}

TEST(DaemonProgrammes, AnUnknownKeyInAProgrammeIsRefusedNamingIt) {
  TempDir dir;
  auto daemon = DaemonProcess::sim(dir.path(), 100);
  Client c(socket_of(dir));
  const json positions = json::array({{{"alpha1_deg", 0}, {"alpha2_deg", 0}}});
  std::string m = refusal(c, "run.start",
                          {{"program", {{"name", "p"}, {"positions", positions}, {"dwel_s", 5}}},
                           {"unit_serial", "AU-9"}},
                          -32602);
  EXPECT_NE(m.find("dwel_s"), std::string::npos) << m;
  m = refusal(c, "run.start", one_position({{"alpha1_deg", 0}, {"alpha2_deg", 0}, {"mnt", "y"}}),
              -32602);
  EXPECT_NE(m.find("mnt"), std::string::npos) << m;
  m = refusal(c, "run.start",
              {{"program", {{"name", 5}, {"positions", positions}}}, {"unit_serial", "AU-9"}},
              -32602);
  EXPECT_NE(m.find("name"), std::string::npos) << m;
  EXPECT_TRUE(c.call("runs.list")["runs"].empty());
}
