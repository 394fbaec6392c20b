// Load (ctest label `load`): 64 clients on the real standcald during a full simulated run
// at high time acceleration. Subscribers that keep reading see every event of the run,
// in order and all the same; a subscriber that stops reading is dropped (a log line and
// `dropped_clients`), and the run still completes: the sequencer never waits for a
// client. Requesters are answered all along. Takes a few seconds.
#include <gtest/gtest.h>
#include <poll.h>
#include <sys/socket.h>

#include <atomic>
#include <fstream>
#include <mutex>
#include <thread>

#include "calib/programs.hpp"
#include "daemon_process.hpp"

using namespace standcal;
using namespace std::chrono_literals;
using nlohmann::json;
using protocol::Client;
using protocol::RpcError;
using test::DaemonProcess;
using test::TempDir;

namespace {

constexpr int kFastSubscribers = 40;
constexpr int kRequesters = 22;      // + 1 slow subscriber + 1 controlling client = 64 clients
constexpr int kProgramRepeats = 12;  // paper9 twelve times over: 108 positions, ~540 events

// One event as a line that must be identical for every subscriber.
std::string event_key(const json& n) {
  const json& p = n["params"];
  std::string key = n["method"].get<std::string>();
  for (const char* field : {"state", "position", "phase", "positions_done"}) {
    if (p.contains(field)) key += std::string(" ") + field + "=" + p[field].dump();
  }
  return key;
}

struct SubscriberLog {
  std::vector<std::string> keys;
  std::vector<int> reached, averaged;  // positions, in arrival order
  std::size_t bytes = 0;
  bool saw_end = false;
  std::string failure;
};

// Reads events until the run's final state arrives (or the deadline).
void follow(Client& c, SubscriberLog& log, std::chrono::steady_clock::time_point deadline) {
  try {
    while (std::chrono::steady_clock::now() < deadline) {
      auto n = c.next_notification(200ms);
      if (!n) continue;
      log.bytes += n->dump().size() + 1;
      log.keys.push_back(event_key(*n));
      const std::string method = (*n)["method"];
      const json& p = (*n)["params"];
      if (method == "run.position_reached") log.reached.push_back(p["position"]);
      if (method == "run.position_averaged") log.averaged.push_back(p["position"]);
      if (method == "run.state" && p["state"] != "running") {
        log.saw_end = true;
        return;
      }
    }
    log.failure = "no final run.state before the deadline";
  } catch (const std::exception& e) {
    log.failure = e.what();
  }
}

// Everything a requester checks in one round: each answer comes, and is the right kind.
void request_round(Client& c, const std::string& run_id) {
  if (c.call("status", json::object(), 30s)["daemon"]["protocol"] != "1")
    throw std::runtime_error("status: bad answer");
  if (!c.call("run.status", {{"run_id", run_id}}, 30s).contains("state"))
    throw std::runtime_error("run.status: no state");
  if (!c.call("runs.list", json::object(), 30s)["runs"].is_array())
    throw std::runtime_error("runs.list: no runs");
  try {
    c.call("operator.confirm", json::object(), 30s);  // through the sequencer's queue
    throw std::runtime_error("operator.confirm succeeded with nothing waiting");
  } catch (const RpcError& e) {
    if (e.code() != -32007) throw std::runtime_error(std::string("operator.confirm: ") + e.what());
  }
}

// Reads what the daemon sent a client until it closes the connection; false if it is
// still open at the deadline. `bytes` counts what had reached the client.
bool closed_by_daemon(int fd, std::chrono::seconds within, std::size_t& bytes) {
  const auto deadline = std::chrono::steady_clock::now() + within;
  char buf[65536];
  while (std::chrono::steady_clock::now() < deadline) {
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, 100) <= 0) continue;
    const ssize_t n = ::recv(fd, buf, sizeof buf, MSG_DONTWAIT);
    if (n == 0) return true;
    if (n < 0 && errno != EAGAIN && errno != EINTR) return true;  // reset
    if (n > 0) bytes += static_cast<std::size_t>(n);
  }
  return false;
}

json repeated_paper9(int repeats) {
  Program p;
  p.name = "paper9x" + std::to_string(repeats);
  for (int r = 0; r < repeats; ++r) {
    for (const auto& pos : paper9().positions) p.positions.push_back(pos);
  }
  return program_to_json(p);
}

}  // namespace

TEST(DaemonLoad, SixtyFourClientsDuringARunSubscribersSeeEveryEventAndASlowOneIsDropped) {
  TempDir dir;
  const std::string socket = dir.path() + "/standcald.sock";
  // The smallest per-client queue the config allows, so the slow subscriber overflows it
  // within one run's events.
  const std::string config = dir.path() + "/standcald.json";
  std::ofstream(config) << json{
      {"socket", {{"path", socket}}},
      {"state_dir", dir.path() + "/state"},
      {"client_queue_bytes",
       65536}}.dump();
  DaemonProcess daemon(dir.path(), {"--config", config, "--sim", "--time-scale", "1000"});
  daemon.wait_ready(socket);

  std::vector<std::unique_ptr<Client>> fast;
  for (int i = 0; i < kFastSubscribers; ++i) {
    fast.push_back(std::make_unique<Client>(socket));
    fast.back()->call("subscribe", {{"events", "all"}});
  }
  Client slow(socket);
  slow.call("subscribe", {{"events", "all"}});  // ... and never reads again
  std::vector<std::unique_ptr<Client>> requesters;
  for (int i = 0; i < kRequesters; ++i) requesters.push_back(std::make_unique<Client>(socket));
  Client control(socket);
  ASSERT_EQ(control.call("status")["daemon"]["clients"], 64);

  const json program = repeated_paper9(kProgramRepeats);
  const int positions = static_cast<int>(program["positions"].size());
  const auto t0 = std::chrono::steady_clock::now();
  const std::string run_id = control.call("run.start", {{"program", program},
                                                        {"unit_serial", "AU-LOAD"},
                                                        {"dwell_s", 1},
                                                        {"settle_s", 0.2}})["run_id"];
  const auto deadline = t0 + 120s;  // generous: a few seconds on an idle machine

  std::vector<SubscriberLog> logs(kFastSubscribers);
  std::atomic<bool> run_over{false};
  std::atomic<long> requests_answered{0};
  std::mutex failures_mutex;
  std::vector<std::string> requester_failures;
  std::vector<std::thread> threads;
  for (int i = 0; i < kFastSubscribers; ++i) {
    threads.emplace_back([&, i] {
      follow(*fast[static_cast<std::size_t>(i)], logs[static_cast<std::size_t>(i)], deadline);
    });
  }
  for (int i = 0; i < kRequesters; ++i) {
    threads.emplace_back([&, i] {
      try {
        while (!run_over && std::chrono::steady_clock::now() < deadline) {
          request_round(*requesters[static_cast<std::size_t>(i)], run_id);
          requests_answered += 4;
        }
      } catch (const std::exception& e) {
        std::lock_guard lock(failures_mutex);
        requester_failures.push_back(e.what());
      }
    });
  }
  json final_status;
  while (std::chrono::steady_clock::now() < deadline) {
    final_status = control.call("run.status", {{"run_id", run_id}}, 30s);
    if (final_status["state"] != "running") break;
    std::this_thread::sleep_for(50ms);
  }
  const double run_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  run_over = true;
  for (auto& t : threads) t.join();

  // The run completed although one subscriber never read a byte of it.
  ASSERT_EQ(final_status["state"], "done") << final_status.dump() << daemon.log();
  EXPECT_EQ(final_status["positions_done"], positions);
  EXPECT_TRUE(requester_failures.empty()) << requester_failures.front();
  EXPECT_GT(requests_answered.load(), 0);

  // Every subscriber that kept reading saw every position event once, in order, and
  // exactly the same stream as every other.
  std::vector<int> expected(static_cast<std::size_t>(positions));
  for (int k = 0; k < positions; ++k) expected[static_cast<std::size_t>(k)] = k + 1;
  for (int i = 0; i < kFastSubscribers; ++i) {
    const SubscriberLog& log = logs[static_cast<std::size_t>(i)];
    ASSERT_TRUE(log.failure.empty()) << "subscriber " << i << ": " << log.failure;
    EXPECT_TRUE(log.saw_end) << "subscriber " << i;
    EXPECT_EQ(log.reached, expected) << "subscriber " << i << ": run.position_reached";
    EXPECT_EQ(log.averaged, expected) << "subscriber " << i << ": run.position_averaged";
    EXPECT_EQ(log.keys, logs[0].keys)
        << "subscriber " << i << " saw a different event stream than subscriber 0";
  }

  // The slow subscriber was dropped, with a notice in the log and in the status.
  std::size_t slow_bytes = 0;
  EXPECT_TRUE(closed_by_daemon(slow.fd(), 10s, slow_bytes))
      << "the slow subscriber is still connected";
  const json daemon_status = control.call("status")["daemon"];
  EXPECT_EQ(daemon_status["dropped_clients"], 1) << "only the slow subscriber may be dropped";
  const std::string notice = "dropped uid " + std::to_string(::geteuid()) + " gid " +
                             std::to_string(::getegid()) + " pid " + std::to_string(::getpid()) +
                             ": it stopped reading";
  EXPECT_NE(daemon.log().find(notice), std::string::npos) << daemon.log();

  std::printf(
      "[load] %d positions, %zu events (%zu bytes) per subscriber, run %.2f s, %ld requests "
      "answered "
      "meanwhile by %d requesters, %d subscribers kept up, 1 slow subscriber dropped after %zu "
      "bytes had "
      "reached it\n",
      positions, logs[0].keys.size(), logs[0].bytes, run_s, requests_answered.load(), kRequesters,
      kFastSubscribers, slow_bytes);
}
