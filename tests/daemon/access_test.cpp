// Access control (docs/security.md): who may command the stand and runs, and who may only
// read. First the decision itself (a pure function of the peer and the policy), then the
// real daemon: the socket file's mode and group, a control group checked against a
// client that really runs as another user (a forked child that drops to `nobody`), and
// the TCP listener's token.
#include <grp.h>
#include <gtest/gtest.h>
#include <pwd.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <functional>

#include "config_support.hpp"
#include "daemon/standcald/config.hpp"
#include "daemon/standcald/server.hpp"
#include "daemon_process.hpp"

using namespace standcal;
using namespace standcal::daemon;
using namespace std::chrono_literals;
using nlohmann::json;
using protocol::Client;
using protocol::RpcError;
using test::config_error;
using test::DaemonProcess;
using test::exits_with_message;
using test::TempDir;

namespace {

constexpr gid_t kOperatorsGid = 4242;

AccessPolicy group_policy() {
  AccessPolicy p;
  p.control_group = "operators";
  p.control_gid = kOperatorsGid;
  p.daemon_uid = 990;
  p.tcp_token_configured = true;
  return p;
}

Peer unix_peer(uid_t uid, gid_t gid, std::vector<gid_t> groups = {}) {
  Peer p;
  p.credentials_known = true;
  p.pid = 1234;
  p.uid = uid;
  p.gid = gid;
  p.groups = std::move(groups);
  return p;
}

Peer tcp_peer(bool token_accepted) {
  Peer p;
  p.tcp = true;
  p.address = "192.0.2.7:40000";
  p.token_accepted = token_accepted;
  return p;
}

// (`hello` is not here: the daemon sends it, no client calls it; a client that does gets
// "unknown method", as for any name standcald does not have.)
const std::vector<std::string> kReadOnly{"status",    "run.status", "run.result",  "runs.list",
                                         "subscribe", "auth",       "run.diagnose"};
const std::vector<std::string> kControl{
    "stand.enable", "stand.disable", "stand.home", "stand.move", "stand.stop", "estop.reset",
    "unit.read",    "run.start",     "run.pause",  "run.resume", "run.abort",  "operator.confirm"};

}  // namespace

// --- The decision -----------------------------------------------------------------------

TEST(AccessDecision, ReadOnlyMethodsAndEstopAreOpenToEveryone) {
  const AccessPolicy policy = group_policy();
  const Peer stranger = unix_peer(1000, 1000, {1000});
  AccessPolicy no_token = policy;
  no_token.tcp_token_configured = false;
  for (const auto& method : kReadOnly) {
    EXPECT_FALSE(refuse_control(method, stranger, policy)) << method;
    EXPECT_FALSE(refuse_control(method, tcp_peer(false), policy)) << method;
    EXPECT_FALSE(refuse_control(method, tcp_peer(false), no_token)) << method;
  }
  // Whoever sees the stand misbehave must be able to stop it.
  EXPECT_FALSE(refuse_control("estop", stranger, policy));
  EXPECT_FALSE(refuse_control("estop", tcp_peer(false), no_token));
  EXPECT_FALSE(refuse_control("estop", unix_peer(1000, 1000), policy));
}

TEST(AccessDecision, ControlMethodsNeedTheControlGroupOnTheUnixSocket) {
  const AccessPolicy policy = group_policy();
  for (const auto& method : kControl) {
    const auto refusal = refuse_control(method, unix_peer(1000, 1000, {1000, 27}), policy);
    ASSERT_TRUE(refusal) << method;
    // The message names the method, the group, the config key and who asked.
    EXPECT_NE(refusal->find(method + " not permitted"), std::string::npos) << *refusal;
    EXPECT_NE(refusal->find("\"operators\""), std::string::npos) << *refusal;
    EXPECT_NE(refusal->find("access.control_group"), std::string::npos) << *refusal;
    EXPECT_NE(refusal->find("uid 1000 gid 1000"), std::string::npos) << *refusal;

    EXPECT_FALSE(refuse_control(method, unix_peer(1000, 1000, {27, kOperatorsGid}), policy))
        << "supplementary";
    EXPECT_FALSE(refuse_control(method, unix_peer(1000, kOperatorsGid), policy)) << "primary group";
    EXPECT_FALSE(refuse_control(method, unix_peer(0, 0), policy)) << "root";
    EXPECT_FALSE(refuse_control(method, unix_peer(990, 990), policy)) << "the daemon's own user";
  }
}

TEST(AccessDecision, APeerWhoseCredentialsAreUnknownIsRefusedControl) {
  Peer unknown;
  const auto refusal = refuse_control("run.start", unknown, group_policy());
  ASSERT_TRUE(refusal);
  EXPECT_NE(refusal->find("SO_PEERCRED"), std::string::npos) << *refusal;
  EXPECT_FALSE(refuse_control("status", unknown, group_policy()));
}

TEST(AccessDecision, WithoutAControlGroupEveryUnixPeerMayCommand) {
  AccessPolicy open;  // no control_group: the socket file's mode and group are the only gate
  for (const auto& method : kControl)
    EXPECT_FALSE(refuse_control(method, unix_peer(1000, 1000), open)) << method;
}

TEST(AccessDecision, TcpClientsGetControlOnlyWithTheToken) {
  AccessPolicy open;  // even with no control group: TCP never gets control without a token
  open.tcp_token_configured = true;
  for (const auto& method : kControl) {
    const auto refusal = refuse_control(method, tcp_peer(false), open);
    ASSERT_TRUE(refusal) << method;
    EXPECT_NE(refusal->find("auth"), std::string::npos) << *refusal;
    EXPECT_FALSE(refuse_control(method, tcp_peer(true), open)) << method;
  }
  AccessPolicy no_token;
  const auto refusal = refuse_control("stand.move", tcp_peer(false), no_token);
  ASSERT_TRUE(refusal);
  EXPECT_NE(refusal->find("no tcp.token_file"), std::string::npos) << *refusal;
}

TEST(AccessDecision, AMethodNobodyListedAsReadOnlyIsAControlMethod) {
  // Default deny: a method added later is restricted until someone lists it as open.
  EXPECT_TRUE(refuse_control("stand.calibrate_encoders", unix_peer(1000, 1000), group_policy()));
  EXPECT_FALSE(is_open_method("stand.calibrate_encoders"));
  EXPECT_TRUE(is_open_method("estop"));
  EXPECT_FALSE(is_open_method("estop.reset"));
}

TEST(AccessDecision, TokensCompareWhole) {
  const std::string token = "3f9c1a7e5b2d4c6e8a0b1c2d3e4f5a6b";
  EXPECT_TRUE(tokens_equal(token, token));
  EXPECT_FALSE(tokens_equal(token.substr(0, 31) + "c", token));  // last character differs
  EXPECT_FALSE(tokens_equal(token.substr(0, 16), token));        // a prefix
  EXPECT_FALSE(tokens_equal(token + token, token));              // the token twice
  EXPECT_FALSE(tokens_equal("", token));
  EXPECT_FALSE(tokens_equal("", ""));  // no token configured: nothing matches
}

// --- The config keys --------------------------------------------------------------------

TEST(AccessConfig, ReadsTheAccessKeys) {
  const DaemonConfig c = parse_config(json::parse(R"({
    "socket": {"path": "/tmp/x.sock", "group": "standcal", "mode": "0640"},
    "tcp": {"enabled": true, "port": 4871, "bind": "0.0.0.0", "token_file": "/etc/standcal/tcp.token"},
    "access": {"control_group": "standcal-operators"},
    "client_queue_bytes": 131072})"),
                                      "lab.json");
  EXPECT_EQ(c.socket_mode, 0640u);
  EXPECT_EQ(c.tcp_bind, "0.0.0.0");
  EXPECT_EQ(c.tcp_token_file, "/etc/standcal/tcp.token");
  EXPECT_EQ(c.control_group, "standcal-operators");
  EXPECT_EQ(c.client_queue_bytes, 131072u);
  const DaemonConfig d = parse_config(json::object(), "lab.json");
  EXPECT_EQ(d.socket_mode, 0660u);
  EXPECT_EQ(d.tcp_bind, "127.0.0.1");
  EXPECT_TRUE(d.control_group.empty());
}

TEST(AccessConfig, BadAccessKeysAreErrorsNamingTheKey) {
  EXPECT_NE(config_error(json::parse(R"({"socket": {"mode": 660}})"))
                .find("socket.mode: must be a string"),
            std::string::npos);
  EXPECT_NE(config_error(json::parse(R"({"socket": {"mode": "0968"}})"))
                .find("socket.mode: must be an octal string"),
            std::string::npos);
  EXPECT_NE(config_error(json::parse(R"({"socket": {"mode": "0066"}})"))
                .find("socket.mode: must give the owner"),
            std::string::npos);
  EXPECT_NE(config_error(json::parse(R"({"tcp": {"bind": "localhost"}})"))
                .find("tcp.bind: must be a numeric"),
            std::string::npos);
  // Off loopback without a token the daemon refuses to start.
  const std::string open_tcp =
      config_error(json::parse(R"({"tcp": {"enabled": true, "bind": "0.0.0.0"}})"));
  EXPECT_NE(open_tcp.find(
                "lab.json: tcp.token_file: is required when tcp.bind (0.0.0.0) is not a loopback"),
            std::string::npos)
      << open_tcp;
  EXPECT_EQ(config_error(json::parse(R"({"tcp": {"enabled": true, "bind": "::1"}})")), "");
  EXPECT_EQ(config_error(json::parse(R"({"tcp": {"enabled": true, "bind": "127.0.0.2"}})")), "");
  EXPECT_NE(config_error(json::parse(R"({"access": {"control_grp": "x"}})"))
                .find("access.control_grp: unknown key"),
            std::string::npos);
  EXPECT_NE(config_error(json::parse(R"({"client_queue_bytes": 100})"))
                .find("client_queue_bytes: must be between"),
            std::string::npos);
}

// An empty group used to mean "no group": with socket mode 0666 every local user could
// then move the stand. A present but empty key is a mistake, not a choice.
TEST(AccessConfig, AnEmptyControlGroupIsAnErrorNamingTheKey) {
  const std::string error = config_error(json::parse(R"({"access": {"control_group": ""}})"));
  EXPECT_NE(error.find("lab.json: access.control_group: must not be empty"), std::string::npos)
      << error;
  EXPECT_EQ(config_error(json::parse(R"({"access": {}})")), "");
  // The other keys whose empty value would silently mean "none".
  EXPECT_NE(config_error(json::parse(R"({"socket": {"group": ""}})"))
                .find("socket.group: must not be empty"),
            std::string::npos);
  EXPECT_NE(config_error(json::parse(R"({"tcp": {"token_file": ""}})"))
                .find("tcp.token_file: must not be empty"),
            std::string::npos);
}

TEST(AccessConfig, TheExampleConfigIsValid) {
  const auto example =
      std::filesystem::path(STANDCAL_SOURCE_DIR) / "systemd/standcald.example.json";
  const DaemonConfig c = load_config(example.string());
  EXPECT_EQ(c.socket_mode, 0660u);
  EXPECT_EQ(c.control_group, "standcal-ops");
  EXPECT_TRUE(is_loopback_address(c.tcp_bind));
}

TEST(AccessConfig, LoopbackAddresses) {
  EXPECT_TRUE(is_loopback_address("127.0.0.1"));
  EXPECT_TRUE(is_loopback_address("127.255.0.9"));
  EXPECT_TRUE(is_loopback_address("::1"));
  EXPECT_FALSE(is_loopback_address("0.0.0.0"));
  EXPECT_FALSE(is_loopback_address("::"));
  EXPECT_FALSE(is_loopback_address("192.168.1.20"));
  EXPECT_FALSE(is_loopback_address("128.0.0.1"));
  EXPECT_FALSE(is_loopback_address("localhost"));  // names are not resolved
}

TEST(AccessConfig, TheTokenFileMustBeLongAndNotReadableByEveryone) {
  TempDir dir;
  DaemonConfig c;
  c.source = "lab.json";
  c.tcp_token_file = dir.path() + "/tcp.token";
  std::ofstream(c.tcp_token_file) << "0123456789abcdef0123\n";
  ::chmod(c.tcp_token_file.c_str(), 0640);
  EXPECT_EQ(load_tcp_token(c), "0123456789abcdef0123");  // the line ending is not part of it

  ::chmod(c.tcp_token_file.c_str(), 0644);
  try {
    load_tcp_token(c);
    ADD_FAILURE() << "a world-readable token file was accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("is readable by every user"), std::string::npos)
        << e.what();
  }
  std::ofstream(c.tcp_token_file) << "short\n";
  ::chmod(c.tcp_token_file.c_str(), 0600);
  try {
    load_tcp_token(c);
    ADD_FAILURE() << "a 5-character token was accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("at least 16 characters"), std::string::npos) << e.what();
  }
  c.tcp_token_file = dir.path() + "/missing.token";
  EXPECT_THROW(load_tcp_token(c), ConfigError);
}

// --- The real daemon ----------------------------------------------------------------------

namespace {

// What one call did, as JSON: {"result": …} or {"code": C, "message": "…"}.
json outcome(Client& c, const std::string& method, const json& params = json::object()) {
  try {
    return json{{"result", c.call(method, params, 20s)}};
  } catch (const RpcError& e) {
    return json{{"code", e.code()}, {"message", e.what()}};
  } catch (const std::exception& e) {
    return json{{"failure", e.what()}};
  }
}

struct Unprivileged {
  uid_t uid;
  gid_t gid;
};

Unprivileged nobody() {
  const passwd* pw = ::getpwnam("nobody");
  return pw != nullptr ? Unprivileged{pw->pw_uid, pw->pw_gid} : Unprivileged{65534, 65534};
}

// Runs `body` in a forked child that has become `nobody` with exactly the supplementary
// groups given, and returns the JSON the body returned (through a pipe). The daemon
// sees this child's real credentials, as it would see an operator's `standcal`.
json as_nobody(const std::vector<gid_t>& groups, const std::function<json()>& body) {
  int pipe_fds[2];
  if (::pipe(pipe_fds) != 0) throw std::runtime_error("pipe failed");
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::close(pipe_fds[0]);
    const Unprivileged who = nobody();
    json answer;
    if (::setgroups(groups.size(), groups.data()) != 0 || ::setgid(who.gid) != 0 ||
        ::setuid(who.uid) != 0 || ::getuid() != who.uid) {
      answer = json{{"failure", "could not drop privileges"}};
    } else {
      try {
        answer = body();
      } catch (const std::exception& e) {
        answer = json{{"failure", std::string("child: ") + e.what()}};
      }
    }
    const std::string text = answer.dump();
    [[maybe_unused]] const ssize_t n = ::write(pipe_fds[1], text.data(), text.size());
    ::_exit(0);
  }
  ::close(pipe_fds[1]);
  std::string text;
  char buf[4096];
  for (ssize_t n; (n = ::read(pipe_fds[0], buf, sizeof buf)) > 0;)
    text.append(buf, static_cast<std::size_t>(n));
  ::close(pipe_fds[0]);
  int status = 0;
  ::waitpid(pid, &status, 0);
  if (text.empty()) return json{{"failure", "the child wrote nothing"}};
  return json::parse(text);
}

// A group that exists on every Debian system, to stand for the lab's operators group.
std::optional<gid_t> test_group_gid(const char* name) {
  const group* g = ::getgrnam(name);
  if (g == nullptr) return std::nullopt;
  return g->gr_gid;
}

constexpr const char* kTestGroup = "operator";

// A daemon started with `config` (plus socket, state dir, the simulated backend).
std::unique_ptr<DaemonProcess> start_daemon(const TempDir& dir, json config) {
  config["socket"]["path"] = dir.path() + "/standcald.sock";
  config["state_dir"] = dir.path() + "/state";
  const std::string file = dir.path() + "/standcald.json";
  std::ofstream(file) << config.dump(2);
  auto d = std::make_unique<DaemonProcess>(
      dir.path(), std::vector<std::string>{"--config", file, "--sim", "--time-scale", "100"});
  d->wait_ready(dir.path() + "/standcald.sock");
  return d;
}

int tcp_port_of(const DaemonProcess& d) {
  const std::string log = d.log();
  const std::string marker = "standcald: tcp port ";
  const auto at = log.find(marker);
  return at == std::string::npos ? 0 : std::atoi(log.c_str() + at + marker.size());
}

#define REQUIRE_ROOT_AND_TEST_GROUP()                                            \
  if (::geteuid() != 0)                                                          \
    GTEST_SKIP() << "needs root: the test drops a child process to user nobody"; \
  if (!test_group_gid(kTestGroup))                                               \
    GTEST_SKIP() << "needs the group \"" << kTestGroup << "\" (Debian base)";

}  // namespace

TEST(DaemonAccess, TheSocketFileGetsTheConfiguredModeAndGroupAndOnlyTheGroupCanConnect) {
  REQUIRE_ROOT_AND_TEST_GROUP();
  TempDir dir;
  ::chmod(dir.path().c_str(), 0755);  // let `nobody` reach the socket file; its mode decides
  auto daemon = start_daemon(dir, json{{"socket", {{"mode", "0660"}, {"group", kTestGroup}}}});
  const std::string socket = dir.path() + "/standcald.sock";
  struct stat st {};
  ASSERT_EQ(::lstat(socket.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 07777, 0660u);
  EXPECT_EQ(st.st_gid, *test_group_gid(kTestGroup));

  auto connect_and_read = [&socket] {
    try {
      Client c(socket, 5s);
      return json{{"connected", true}, {"status", outcome(c, "status")}};
    } catch (const std::exception& e) {
      return json{{"connected", false}, {"error", e.what()}};
    }
  };
  const json outsider = as_nobody({}, connect_and_read);
  ASSERT_FALSE(outsider.contains("failure")) << outsider.dump();
  EXPECT_FALSE(outsider["connected"].get<bool>()) << outsider.dump();  // EACCES from the file mode
  const json member = as_nobody({*test_group_gid(kTestGroup)}, connect_and_read);
  ASSERT_TRUE(member["connected"].get<bool>()) << member.dump();
  EXPECT_EQ(member["status"]["result"]["daemon"]["protocol"], "1");
}

TEST(DaemonAccess, AControlGroupRefusesOthersMotionButLeavesReadingAndEstopOpen) {
  REQUIRE_ROOT_AND_TEST_GROUP();
  TempDir dir;
  ::chmod(dir.path().c_str(), 0755);
  // Everyone may connect (0666); only the control group may command.
  auto daemon = start_daemon(
      dir, json{{"socket", {{"mode", "0666"}}}, {"access", {{"control_group", kTestGroup}}}});
  const std::string socket = dir.path() + "/standcald.sock";

  const json outsider = as_nobody({}, [&socket] {
    Client c(socket, 5s);
    json r;
    r["status"] = outcome(c, "status");
    r["runs.list"] = outcome(c, "runs.list");
    r["subscribe"] = outcome(c, "subscribe", {{"events", "all"}});
    r["stand.enable"] = outcome(c, "stand.enable");
    r["run.start"] = outcome(c, "run.start", {{"program", "paper9"}, {"unit_serial", "AU-X"}});
    r["estop.reset"] = outcome(c, "estop.reset");
    r["estop"] = outcome(c, "estop");
    return r;
  });
  ASSERT_FALSE(outsider.contains("failure")) << outsider.dump();
  EXPECT_EQ(outsider["status"]["result"]["daemon"]["access"]["control"], false) << outsider.dump();
  EXPECT_TRUE(outsider["runs.list"].contains("result")) << outsider.dump();
  EXPECT_TRUE(outsider["subscribe"].contains("result")) << outsider.dump();
  for (const char* refused : {"stand.enable", "run.start", "estop.reset"}) {
    EXPECT_EQ(outsider[refused]["code"], static_cast<int>(protocol::ErrorCode::not_permitted))
        << outsider.dump();
    const std::string message = outsider[refused].value("message", "");
    EXPECT_NE(message.find(std::string(refused) + " not permitted"), std::string::npos) << message;
    EXPECT_NE(message.find(std::string("\"") + kTestGroup + "\""), std::string::npos) << message;
    EXPECT_NE(message.find("uid " + std::to_string(nobody().uid)), std::string::npos) << message;
  }
  // estop is never restricted: it worked, and the latch is visible to everyone.
  EXPECT_EQ(outsider["estop"]["result"]["estop"], true) << outsider.dump();
  Client root(socket);
  EXPECT_EQ(root.call("status")["stand"]["estop_latched"], true);
  EXPECT_EQ(root.call("status")["daemon"]["access"]["control"], true);  // root may

  // A member of the group (here only as a supplementary group) may command.
  const json member = as_nobody({*test_group_gid(kTestGroup)}, [&socket] {
    Client c(socket, 5s);
    json r;
    r["estop.reset"] = outcome(c, "estop.reset");
    r["stand.enable"] = outcome(c, "stand.enable");
    r["status"] = outcome(c, "status");
    return r;
  });
  EXPECT_EQ(member["estop.reset"]["result"]["estop"], false) << member.dump();
  EXPECT_EQ(member["stand.enable"]["result"]["enabled"], true) << member.dump();
  EXPECT_EQ(member["status"]["result"]["daemon"]["access"]["control"], true) << member.dump();
}

TEST(DaemonAccess, TcpOffLoopbackNeedsTheTokenForControlAndAWrongTokenClosesTheConnection) {
  TempDir dir;
  const std::string token_file = dir.path() + "/tcp.token";
  const std::string token = "9d2f6c1b8e4a7d3c5b0e9f1a2c4d6e8f";
  std::ofstream(token_file) << token << "\n";
  ::chmod(token_file.c_str(), 0600);
  auto daemon = start_daemon(
      dir,
      json{{"tcp",
            {{"enabled", true}, {"port", 0}, {"bind", "0.0.0.0"}, {"token_file", token_file}}}});
  const int port = tcp_port_of(*daemon);
  ASSERT_GT(port, 0) << daemon->log();
  const std::string endpoint = "tcp://127.0.0.1:" + std::to_string(port);

  Client reader(endpoint);
  EXPECT_EQ(reader.call("status")["daemon"]["access"]["control"], false);
  const json refused = outcome(reader, "stand.enable");
  EXPECT_EQ(refused["code"], static_cast<int>(protocol::ErrorCode::not_permitted))
      << refused.dump();
  EXPECT_NE(refused.value("message", "").find("auth"), std::string::npos) << refused.dump();
  EXPECT_EQ(outcome(reader, "estop")["result"]["estop"], true);  // never restricted

  Client guesser(endpoint);
  const json wrong = outcome(guesser, "auth", {{"token", token.substr(0, 31) + "0"}});
  EXPECT_EQ(wrong["code"], static_cast<int>(protocol::ErrorCode::not_permitted)) << wrong.dump();
  EXPECT_NE(wrong.value("message", "").find("wrong token"), std::string::npos) << wrong.dump();
  EXPECT_THROW(guesser.call("status", json::object(), 10s), std::exception)
      << "the connection stays open";

  Client operator_client(endpoint);
  EXPECT_EQ(operator_client.call("auth", {{"token", token}})["control"], true);
  EXPECT_EQ(operator_client.call("estop.reset")["estop"], false);
  EXPECT_EQ(operator_client.call("stand.enable")["enabled"], true);
  EXPECT_EQ(operator_client.call("status")["daemon"]["access"]["control"], true);
  // The token belongs to that connection only.
  EXPECT_EQ(outcome(reader, "stand.disable")["code"],
            static_cast<int>(protocol::ErrorCode::not_permitted));
  EXPECT_NE(daemon->log().find("auth: wrong token from tcp 127.0.0.1:"), std::string::npos)
      << daemon->log();
}

TEST(DaemonAccess, LoopbackTcpWithoutATokenIsReadOnlyPlusEstop) {
  TempDir dir;
  auto daemon = start_daemon(dir, json{{"tcp", {{"enabled", true}, {"port", 0}}}});
  const int port = tcp_port_of(*daemon);
  ASSERT_GT(port, 0) << daemon->log();
  Client c("tcp://127.0.0.1:" + std::to_string(port));
  EXPECT_EQ(c.call("runs.list")["runs"].size(), 0u);
  const json refused = outcome(c, "run.start", {{"program", "paper9"}, {"unit_serial", "AU-T"}});
  EXPECT_EQ(refused["code"], static_cast<int>(protocol::ErrorCode::not_permitted))
      << refused.dump();
  EXPECT_NE(refused.value("message", "").find("no tcp.token_file"), std::string::npos)
      << refused.dump();
  EXPECT_EQ(outcome(c, "auth", {{"token", "0123456789abcdef"}})["code"],
            static_cast<int>(protocol::ErrorCode::not_permitted));
  EXPECT_EQ(outcome(c, "estop")["result"]["estop"], true);
  // The Unix socket (root here, no control group) still commands.
  Client local(dir.path() + "/standcald.sock");
  EXPECT_EQ(local.call("estop.reset")["estop"], false);
}

TEST(DaemonAccess, TheDaemonRefusesToStartOffLoopbackWithoutAUsableToken) {
  {
    TempDir dir;
    const std::string file = dir.path() + "/standcald.json";
    std::ofstream(file) << json{{"socket", {{"path", dir.path() + "/s.sock"}}},
                                {"state_dir", dir.path() + "/state"},
                                {"tcp", {{"enabled", true}, {"bind", "0.0.0.0"}}}}
                               .dump();
    DaemonProcess d(dir.path(), {"--config", file, "--sim"});
    EXPECT_TRUE(exits_with_message(
        d, "tcp.token_file: is required when tcp.bind (0.0.0.0) is not a loopback address"))
        << d.log();
  }
  {
    TempDir dir;
    const std::string token_file = dir.path() + "/tcp.token";
    std::ofstream(token_file) << "9d2f6c1b8e4a7d3c5b0e9f1a2c4d6e8f\n";
    ::chmod(token_file.c_str(), 0644);
    const std::string file = dir.path() + "/standcald.json";
    std::ofstream(file)
        << json{{"socket", {{"path", dir.path() + "/s.sock"}}},
                {"state_dir", dir.path() + "/state"},
                {"tcp", {{"enabled", true}, {"bind", "0.0.0.0"}, {"token_file", token_file}}}}
               .dump();
    DaemonProcess d(dir.path(), {"--config", file, "--sim"});
    EXPECT_TRUE(exits_with_message(d, "is readable by every user")) << d.log();
  }
  {
    TempDir dir;
    const std::string file = dir.path() + "/standcald.json";
    std::ofstream(file) << json{{"socket", {{"path", dir.path() + "/s.sock"}}},
                                {"state_dir", dir.path() + "/state"},
                                {"access", {{"control_group", "no-such-group-standcal"}}}}
                               .dump();
    DaemonProcess d(dir.path(), {"--config", file, "--sim"});
    EXPECT_TRUE(
        exits_with_message(d, "access.control_group: no group named \"no-such-group-standcal\""))
        << d.log();
  }
}
