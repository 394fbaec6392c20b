// Bad input from one client gets that client an error (or a closed connection) while the
// daemon keeps serving everyone else: malformed JSON, wrong types, unknown methods, an
// oversized line, a client that never reads, too many clients.
#include <gtest/gtest.h>
#include <poll.h>
#include <sys/socket.h>

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

json next_reply(Client& c) {
  auto m = c.next_message(10s);
  if (!m) throw std::runtime_error("no reply within 10 s");
  return *m;
}

// True once the daemon has closed `c`'s connection (EOF or reset), within the timeout.
bool closed_by_daemon(Client& c, std::chrono::seconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < deadline) {
    try {
      while (c.next_message(100ms)) {
      }
    } catch (const std::runtime_error&) {
      return true;  // "closed the connection" / "lost the connection"
    }
  }
  return false;
}

}  // namespace

TEST(DaemonBadInput, ErrorsGoToTheSenderAndOthersAreServed) {
  TempDir dir;
  auto daemon = DaemonProcess::sim(dir.path(), 100);
  Client bad(socket_of(dir));
  Client good(socket_of(dir));

  bad.send_raw("{this is not json\n");
  json r = next_reply(bad);
  EXPECT_EQ(r["error"]["code"], -32700);
  EXPECT_TRUE(r["id"].is_null());

  bad.send_raw(R"({"jsonrpc":"2.0","id":1,"method":"no.such.method"})"
               "\n");
  r = next_reply(bad);
  EXPECT_EQ(r["error"]["code"], -32601);
  EXPECT_EQ(r["id"], 1);

  bad.send_raw(
      R"({"jsonrpc":"2.0","id":2,"method":"stand.move","params":{"alpha1_deg":"ninety","alpha2_deg":0}})"
      "\n");
  r = next_reply(bad);
  EXPECT_EQ(r["error"]["code"], -32602);
  EXPECT_NE(r["error"]["message"].get<std::string>().find("alpha1_deg"), std::string::npos);

  bad.send_raw(
      R"({"jsonrpc":"2.0","id":3,"method":"run.start","params":{"program":"paper9","unit_serial":42}})"
      "\n");
  r = next_reply(bad);
  EXPECT_EQ(r["error"]["code"], -32602);

  bad.send_raw(R"({"id":4,"method":"status"})"
               "\n");
  r = next_reply(bad);
  EXPECT_EQ(r["error"]["code"], -32600);

  bad.send_raw(R"({"jsonrpc":"2.0","id":5,"method":"status","params":{"verbose":true}})"
               "\n");
  r = next_reply(bad);
  EXPECT_EQ(r["error"]["code"], -32602);

  // A notification (no id) gets no answer; the next request's answer comes next.
  bad.send_raw(R"({"jsonrpc":"2.0","method":"status"})"
               "\n"
               R"({"jsonrpc":"2.0","id":6,"method":"status"})"
               "\n");
  r = next_reply(bad);
  EXPECT_EQ(r["id"], 6);

  EXPECT_EQ(good.call("status")["daemon"]["protocol"], "1");
  // The bad client is still connected and served too.
  EXPECT_EQ(bad.call("status")["daemon"]["protocol"], "1");
}

TEST(DaemonBadInput, AnOversizedLineGetsAnErrorAndTheConnectionIsClosed) {
  TempDir dir;
  auto daemon = DaemonProcess::sim(dir.path(), 100);
  Client good(socket_of(dir));
  Client bad(socket_of(dir));
  std::string huge = R"({"jsonrpc":"2.0","id":1,"method":"status","params":{"pad":")";
  huge += std::string(70 * 1024, 'x');
  huge += "\"}}\n";
  bad.send_raw(huge);
  auto r = bad.next_message(10s);
  ASSERT_TRUE(r.has_value());
  EXPECT_EQ((*r)["error"]["code"], -32600);
  EXPECT_NE((*r)["error"]["message"].get<std::string>().find("65536"), std::string::npos);
  EXPECT_TRUE(closed_by_daemon(bad, 10s));
  EXPECT_EQ(good.call("status")["daemon"]["protocol"], "1");
}

TEST(DaemonBadInput, AClientThatNeverReadsIsDroppedWithoutStallingOthers) {
  TempDir dir;
  auto daemon = DaemonProcess::sim(dir.path(), 100);
  Client good(socket_of(dir));
  Client stuck(socket_of(dir));
  // Many requests, never reading a single answer.
  std::string burst;
  for (int i = 0; i < 200; ++i)
    burst += R"({"jsonrpc":"2.0","id":1,"method":"status"})"
             "\n";
  bool dropped = false;
  for (int round = 0; round < 200 && !dropped; ++round) {
    pollfd p{stuck.fd(), POLLOUT, 0};
    if (::poll(&p, 1, 0) == 1 && (p.revents & (POLLERR | POLLHUP))) {
      dropped = true;
      break;
    }
    if ((p.revents & POLLOUT) != 0) {
      const ssize_t n = ::send(stuck.fd(), burst.data(), burst.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
      if (n < 0 && errno != EAGAIN) dropped = true;
    }
    // Meanwhile the other client is answered promptly.
    ASSERT_EQ(good.call("status", json::object(), 10s)["daemon"]["protocol"], "1");
    if (good.call("status")["daemon"]["dropped_clients"].get<int>() >= 1) dropped = true;
  }
  EXPECT_TRUE(dropped);
  EXPECT_GE(good.call("status")["daemon"]["dropped_clients"].get<int>(), 1);
  EXPECT_EQ(good.call("status")["daemon"]["clients"].get<int>(), 1);
}

// Past max_clients a connection gets an estop-only slot (kEstopOnlySlots of them, 16):
// `estop` works there, anything else is refused and closes it; past those too a new
// connection gets -32008 at once.
TEST(DaemonBadInput, PastTheClientLimitOnlyEstopIsServedThenNewConnectionsGetAnError) {
  TempDir dir;
  auto daemon = DaemonProcess::sim(dir.path(), 100);
  std::vector<std::unique_ptr<Client>> clients;
  for (int i = 0; i < 256; ++i) clients.push_back(std::make_unique<Client>(socket_of(dir)));
  Client estop_only(socket_of(dir));
  EXPECT_EQ(estop_only.hello().value("estop_only", false), true) << estop_only.hello().dump();
  try {
    estop_only.call("status");
    ADD_FAILURE() << "status was answered on an estop-only slot";
  } catch (const RpcError& e) {
    EXPECT_EQ(e.code(), -32008) << e.what();
  }
  Client presses(socket_of(dir));
  EXPECT_EQ(presses.call("estop", json::object(), 5s)["estop"], true);
  std::vector<std::unique_ptr<Client>> estop_slots;
  for (int i = 0; i < 16; ++i) estop_slots.push_back(std::make_unique<Client>(socket_of(dir)));
  try {
    Client extra(socket_of(dir));
    FAIL() << "connection 256 + 16 + 1 was accepted";
  } catch (const RpcError& e) {
    EXPECT_EQ(e.code(), -32008);
  }
  // All 256 are served.
  EXPECT_EQ(clients.front()->call("status")["daemon"]["clients"], 256 + 16);
  clients.pop_back();
  estop_slots.clear();
  // A slot is free again once one leaves.
  const auto deadline = std::chrono::steady_clock::now() + 10s;
  for (;;) {
    try {
      Client again(socket_of(dir));
      if (!again.hello().contains("estop_only")) break;
    } catch (const RpcError&) {
    }
    ASSERT_LT(std::chrono::steady_clock::now(), deadline);
    std::this_thread::sleep_for(20ms);
  }
}

// A daemon from a config file with short client timeouts (seconds).
static std::unique_ptr<DaemonProcess> daemon_with_timeouts(const TempDir& dir, double request_s,
                                                           double idle_s) {
  const std::string config = dir.path() + "/standcald.json";
  std::ofstream(config) << json{
      {"socket", {{"path", socket_of(dir)}}},
      {"state_dir", dir.path() + "/state"},
      {"client_request_timeout_s", request_s},
      {"client_idle_timeout_s",
       idle_s}}.dump();
  auto d = std::make_unique<DaemonProcess>(
      dir.path(), std::vector<std::string>{"--config", config, "--sim", "--time-scale", "100"});
  d->wait_ready(socket_of(dir));
  return d;
}

// A request sent a byte every 2 s used to hold its connection for as long as it went on.
TEST(DaemonBadInput, ARequestLineNotEndedWithinTheRequestTimeoutIsClosed) {
  TempDir dir;
  auto daemon = daemon_with_timeouts(dir, 1, 600);
  Client slow(socket_of(dir));
  Client good(socket_of(dir));
  const std::string request = R"({"jsonrpc":"2.0","id":1,"method":"status"})";
  bool closed = false;
  json error;
  // Trickle the request a byte every 0.3 s: it would take 12 s to finish.
  for (std::size_t i = 0; i < request.size() && !closed; ++i) {
    if (::send(slow.fd(), &request[i], 1, MSG_NOSIGNAL) != 1) break;
    try {
      if (auto m = slow.next_message(300ms)) error = *m;
    } catch (const std::runtime_error&) {
      closed = true;
    }
  }
  EXPECT_TRUE(closed || closed_by_daemon(slow, 10s)) << "the trickling client is still connected";
  EXPECT_EQ(error["error"]["code"], -32600) << error.dump();
  EXPECT_NE(error["error"]["message"].get<std::string>().find("client_request_timeout_s"),
            std::string::npos)
      << error.dump();
  EXPECT_EQ(good.call("status")["daemon"]["clients"], 1);
}

TEST(DaemonBadInput, AnIdleClientIsClosedButASubscriberIsKept) {
  TempDir dir;
  auto daemon = daemon_with_timeouts(dir, 10, 1);
  Client idle(socket_of(dir));
  Client subscriber(socket_of(dir));
  subscriber.call("subscribe", {{"events", "all"}});
  EXPECT_TRUE(closed_by_daemon(idle, 20s)) << "the idle client is still connected";
  // The subscriber waited as long without a request, and stays.
  EXPECT_EQ(subscriber.call("status")["daemon"]["clients"], 1);
  EXPECT_NE(daemon->log().find("client_idle_timeout_s"), std::string::npos) << daemon->log();
}

// A NUL in a client's value used to end the error message there ("no run ab").
TEST(DaemonBadInput, ANulInAValueIsKeptEscapedInTheErrorMessage) {
  TempDir dir;
  auto daemon = DaemonProcess::sim(dir.path(), 100);
  Client c(socket_of(dir));
  c.send_raw(R"({"jsonrpc":"2.0","id":1,"method":"run.status","params":{"run_id":"ab\u0000cd"}})"
             "\n");
  json r = next_reply(c);
  // A run id is a text field (checked at the boundary): the error names the NUL and where.
  EXPECT_EQ(r["error"]["code"], -32602) << r.dump();
  EXPECT_NE(r["error"]["message"].get<std::string>().find("U+0000 at character 3"),
            std::string::npos)
      << r.dump();
  c.send_raw(R"({"jsonrpc":"2.0","id":2,"method":"no\u0000such"})"
             "\n");
  r = next_reply(c);
  EXPECT_EQ(r["error"]["code"], -32601) << r.dump();
  EXPECT_NE(r["error"]["message"].get<std::string>().find("no\\0such"), std::string::npos)
      << r.dump();
}

// JSON-RPC 2.0 batches (a JSON array) are not supported: one Invalid Request error with a
// null id answers the whole array (the specification's answer to an empty array too),
// nothing in it is executed, and the connection stays usable.
TEST(DaemonJsonRpc, ABatchGetsOneInvalidRequestErrorSayingBatchesAreNotSupported) {
  TempDir dir;
  auto daemon = DaemonProcess::sim(dir.path(), 100);
  Client c(socket_of(dir));
  const json lifecycle_before = c.call("status")["stand"]["lifecycle"];
  ASSERT_NE(lifecycle_before, "active");
  for (const char* batch :
       {R"([{"jsonrpc":"2.0","id":1,"method":"stand.enable"}])", "[]", "[1,2]"}) {
    c.send_raw(std::string(batch) + "\n");
    const json r = next_reply(c);
    ASSERT_TRUE(r.is_object()) << batch << " -> " << r.dump();
    EXPECT_EQ(r["error"]["code"], -32600) << batch;
    EXPECT_TRUE(r["id"].is_null()) << batch;
    EXPECT_NE(r["error"]["message"].get<std::string>().find("batch"), std::string::npos)
        << r.dump();
  }
  EXPECT_EQ(c.call("status")["stand"]["lifecycle"],
            lifecycle_before);  // the batched stand.enable did not run
}

// The id rules of JSON-RPC 2.0: a request carries an id that is a string, a number or
// null, and its answer carries the same id; a request without an id is a notification
// and gets no answer, not even an error.
TEST(DaemonJsonRpc, EveryIdIsEchoedAndNotificationsAreNeverAnswered) {
  TempDir dir;
  auto daemon = DaemonProcess::sim(dir.path(), 100);
  Client c(socket_of(dir));
  c.send_raw(R"({"jsonrpc":"2.0","id":null,"method":"status"})"
             "\n");
  json r = next_reply(c);
  EXPECT_TRUE(r.contains("id") && r["id"].is_null()) << r.dump();
  EXPECT_TRUE(r.contains("result")) << r.dump();

  c.send_raw(R"({"jsonrpc":"2.0","id":1.5,"method":"status"})"
             "\n");
  r = next_reply(c);
  EXPECT_EQ(r["id"], 1.5) << r.dump();
  EXPECT_TRUE(r.contains("result")) << r.dump();

  c.send_raw(R"({"jsonrpc":"2.0","method":"no.such.method"})"
             "\n"
             R"({"jsonrpc":"2.0","method":"status","params":[1]})"
             "\n"
             R"({"jsonrpc":"2.0","method":"status","params":{"verbose":true}})"
             "\n"
             R"({"jsonrpc":"2.0","id":7,"method":"status"})"
             "\n");
  r = next_reply(c);
  EXPECT_EQ(r["id"], 7) << "a notification was answered: " << r.dump();
  c.send_raw(R"({"jsonrpc":"2.0","id":9,"method":"status","params":[1]})"
             "\n");
  r = next_reply(c);
  EXPECT_EQ(r["error"]["code"], -32602) << r.dump();
  EXPECT_EQ(r["id"], 9);

  // Not a request object at all (params must be an object or an array): an error, id null
  // when none was sent.
  c.send_raw(R"({"jsonrpc":"2.0","id":8,"method":"status","params":5})"
             "\n");
  r = next_reply(c);
  EXPECT_EQ(r["error"]["code"], -32600) << r.dump();
  EXPECT_EQ(r["id"], 8);
  c.send_raw(R"({"jsonrpc":"2.0","method":5})"
             "\n");
  r = next_reply(c);
  EXPECT_EQ(r["error"]["code"], -32600) << r.dump();
  EXPECT_TRUE(r["id"].is_null());
}
