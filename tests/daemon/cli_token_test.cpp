// `standcal --tcp HOST:PORT --token-file FILE` against a real standcald whose TCP listener
// is bound off loopback and so needs the token (docs/security.md): the token is sent with
// `auth` first, a wrong token and a file others may read are clear one-line errors.
#include <sys/stat.h>

#include <cstdio>
#include <fstream>

#include "daemon_process.hpp"
#include "tests/support/command.hpp"

using namespace std::chrono_literals;
using nlohmann::json;
using standcal::test::CommandOutcome;
using standcal::test::DaemonProcess;
using standcal::test::standcal_cli;
using standcal::test::TempDir;

namespace {

constexpr const char* kToken = "5be1c0de9a7f4e2d8c3b6a1f0e9d8c7b";

std::string write_token_file(const TempDir& dir, const std::string& name, const std::string& text,
                             mode_t mode) {
  const std::string path = dir.path() + "/" + name;
  std::ofstream(path) << text;
  ::chmod(path.c_str(), mode);
  return path;
}

// A daemon listening on TCP 0.0.0.0 (any free port) that wants kToken from TCP clients.
class TokenDaemon {
 public:
  explicit TokenDaemon(const TempDir& dir) {
    const std::string token_file =
        write_token_file(dir, "daemon.token", std::string(kToken) + "\n", 0600);
    const std::string config = dir.path() + "/standcald.json";
    std::ofstream(config)
        << json{{"socket", {{"path", dir.path() + "/standcald.sock"}}},
                {"state_dir", dir.path() + "/state"},
                {"tcp",
                 {{"enabled", true}, {"port", 0}, {"bind", "0.0.0.0"}, {"token_file", token_file}}}}
               .dump(2);
    daemon_ = std::make_unique<DaemonProcess>(
        dir.path(), std::vector<std::string>{"--config", config, "--sim", "--time-scale", "100"});
    daemon_->wait_ready(dir.path() + "/standcald.sock");
    const std::string log = daemon_->log();
    const std::string marker = "standcald: tcp port ";
    const auto at = log.find(marker);
    port_ = at == std::string::npos ? 0 : std::atoi(log.c_str() + at + marker.size());
  }
  std::string tcp() const { return "--tcp 127.0.0.1:" + std::to_string(port_); }
  int port() const { return port_; }
  std::string log() const { return daemon_->log(); }

 private:
  std::unique_ptr<DaemonProcess> daemon_;
  int port_ = 0;
};

}  // namespace

TEST(CliTokenFile, TheRightTokenGivesControlOverTcp) {
  TempDir dir;
  TokenDaemon daemon(dir);
  ASSERT_GT(daemon.port(), 0) << daemon.log();
  // Written by an editor on Windows: the CRLF line end is not part of the token.
  const std::string token = write_token_file(dir, "op.token", std::string(kToken) + "\r\n", 0600);

  const CommandOutcome status =
      standcal_cli("status --json " + daemon.tcp() + " --token-file " + token);
  ASSERT_EQ(status.exit_code, 0) << status.output;
  EXPECT_EQ(json::parse(status.output)["daemon"]["access"]["control"], true) << status.output;

  // estop.reset is a control method: refused without the token, done with it.
  const CommandOutcome without = standcal_cli("estop --reset " + daemon.tcp());
  EXPECT_EQ(without.exit_code, 1) << without.output;
  EXPECT_NE(without.output.find("not permitted"), std::string::npos) << without.output;
  const CommandOutcome with =
      standcal_cli("estop --reset --json " + daemon.tcp() + " --token-file " + token);
  ASSERT_EQ(with.exit_code, 0) << with.output;
  EXPECT_EQ(json::parse(with.output)["estop"], false) << with.output;
}

// docs/protocol.md writes the endpoint before the command: `standcal --tcp H:P
// --token-file F run start ...`. That form was refused as a usage error (exit 109).
TEST(CliTokenFile, TheEndpointMayComeBeforeTheCommand) {
  TempDir dir;
  TokenDaemon daemon(dir);
  ASSERT_GT(daemon.port(), 0) << daemon.log();
  const std::string token = write_token_file(dir, "op.token", std::string(kToken) + "\n", 0600);
  const CommandOutcome with =
      standcal_cli(daemon.tcp() + " --token-file " + token + " estop --reset --json");
  ASSERT_EQ(with.exit_code, 0) << with.output;
  EXPECT_EQ(json::parse(with.output)["estop"], false) << with.output;
  // The command's own endpoint wins over the global one.
  const CommandOutcome own = standcal_cli("--tcp 127.0.0.1:9 status --json " + daemon.tcp());
  ASSERT_EQ(own.exit_code, 0) << own.output;
  EXPECT_EQ(json::parse(own.output)["daemon"]["access"]["control"], false) << own.output;
  // A global endpoint for a command that takes none is a usage error.
  const CommandOutcome offline = standcal_cli(daemon.tcp() + " design evaluate paper9");
  EXPECT_EQ(offline.exit_code, 2) << offline.output;
  EXPECT_NE(offline.output.find("--tcp: `design evaluate` does not take it"), std::string::npos)
      << offline.output;
  // The token may go before the command and the endpoint after it.
  const CommandOutcome split =
      standcal_cli("--token-file " + token + " estop --reset --json " + daemon.tcp());
  ASSERT_EQ(split.exit_code, 0) << split.output;
}

TEST(CliTokenFile, AWrongTokenIsReportedAsARefusedToken) {
  TempDir dir;
  TokenDaemon daemon(dir);
  ASSERT_GT(daemon.port(), 0) << daemon.log();
  const std::string wrong =
      write_token_file(dir, "old.token", "0000000000000000000000000000dead\n", 0600);
  const CommandOutcome r = standcal_cli("status " + daemon.tcp() + " --token-file " + wrong);
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("refused the token from " + wrong), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("wrong token"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("not permitted"), std::string::npos) << r.output;
  EXPECT_NE(daemon.log().find("auth: wrong token from tcp 127.0.0.1:"), std::string::npos)
      << daemon.log();
}

TEST(CliTokenFile, AFileOthersMayReadIsRefusedBeforeConnecting) {
  TempDir dir;
  TokenDaemon daemon(dir);
  ASSERT_GT(daemon.port(), 0) << daemon.log();
  for (const mode_t mode : {0640, 0604, 0620}) {
    const std::string file =
        write_token_file(dir, "shared.token", std::string(kToken) + "\n", mode);
    const CommandOutcome r = standcal_cli("status " + daemon.tcp() + " --token-file " + file);
    EXPECT_EQ(r.exit_code, 1) << r.output;
    char expected[64];
    std::snprintf(expected, sizeof expected, "has mode %04o", static_cast<unsigned>(mode));
    EXPECT_NE(r.output.find(expected), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("chmod 600 " + file), std::string::npos) << r.output;
  }
  EXPECT_EQ(daemon.log().find("auth:"), std::string::npos) << "the token was sent anyway:\n"
                                                           << daemon.log();
}

TEST(CliTokenFile, UnusableTokenFilesAndOptionsAreClearErrors) {
  TempDir dir;
  const std::string empty = write_token_file(dir, "empty.token", "\n", 0600);
  const CommandOutcome r1 = standcal_cli("status --tcp 127.0.0.1:9 --token-file " + empty);
  EXPECT_EQ(r1.exit_code, 1) << r1.output;
  EXPECT_NE(r1.output.find("the token file " + empty + " is empty"), std::string::npos)
      << r1.output;

  const CommandOutcome r2 =
      standcal_cli("status --tcp 127.0.0.1:9 --token-file " + dir.path() + "/missing.token");
  EXPECT_EQ(r2.exit_code, 1) << r2.output;
  EXPECT_NE(r2.output.find("cannot open the token file"), std::string::npos) << r2.output;

  // The token goes with `auth`, which only TCP clients send.
  const std::string token = write_token_file(dir, "op.token", std::string(kToken) + "\n", 0600);
  const CommandOutcome r3 =
      standcal_cli("status --socket " + dir.path() + "/s.sock --token-file " + token);
  EXPECT_NE(r3.exit_code, 0) << r3.output;
  EXPECT_NE(r3.output.find("--token-file requires --tcp"), std::string::npos) << r3.output;
}

// --tcp used to go through std::stoi: 99999 wrapped to 34463 (so port + 65536 reached the
// daemon with the token), "abc" printed just "stoi" and "4871x" was taken as 4871.
TEST(CliTcpOption, APortOutOfRangeOrNotWhollyANumberIsRefusedNamingTheOption) {
  TempDir dir;
  TokenDaemon daemon(dir);
  ASSERT_GT(daemon.port(), 0) << daemon.log();
  const std::string token = write_token_file(dir, "op.token", std::string(kToken) + "\n", 0600);
  const std::string wrapped = "127.0.0.1:" + std::to_string(daemon.port() + 65536);
  const std::vector<std::pair<std::string, std::string>> cases{
      {wrapped, "the port '" + std::to_string(daemon.port() + 65536) +
                    "' is not a whole number from 1 to 65535"},
      {"127.0.0.1:abc", "the port 'abc' is not a whole number from 1 to 65535"},
      {"127.0.0.1:" + std::to_string(daemon.port()) + "x",
       "the port '" + std::to_string(daemon.port()) + "x' is not a whole number from 1 to 65535"},
      {"127.0.0.1:0", "the port '0' is not a whole number from 1 to 65535"},
      {"127.0.0.1:", "the port '' is not a whole number"},
      {"127.0.0.1", "no port"},
      {"localhost:4871", "'localhost' is not a numeric IPv4 address"}};
  for (const auto& [value, why] : cases) {
    const CommandOutcome r = standcal_cli("status --tcp " + value + " --token-file " + token);
    EXPECT_EQ(r.exit_code, 1) << value << ": " << r.output;
    EXPECT_NE(r.output.find("--tcp '" + value + "': " + why), std::string::npos)
        << value << ": " << r.output;
    EXPECT_EQ(r.output.find("stoi"), std::string::npos) << r.output;
  }
  EXPECT_EQ(daemon.log().find("auth:"), std::string::npos) << "the token reached the daemon:\n"
                                                           << daemon.log();
  // The same port written plainly still works.
  const CommandOutcome ok =
      standcal_cli("status --json " + daemon.tcp() + " --token-file " + token);
  EXPECT_EQ(ok.exit_code, 0) << ok.output;
}
