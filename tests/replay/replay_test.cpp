// Replay tests: each recorded input under tests/replay/ is replayed through the real code
// path and its output compared, line by line, with the checked-in .chk beside it.
//   can/*.candump     candump -L frames → SocketCanUnit over a socketpair → the samples
//                     and the link counters
//   jsonrpc/*.jsonl   request lines → a real standcald --sim on its Unix socket → the
//                     replies, with the keys a `# mask:` header names masked
// STANDCAL_REPLAY_REGENERATE=1 writes the .chk files from this build instead of comparing.
#include <gtest/gtest.h>
#include <linux/can.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "drivers/socketcan/socketcan_unit.hpp"
#include "tests/daemon/daemon_process.hpp"
#include "tests/drivers_can/can_pair.hpp"
#include "tests/replay/replay_support.hpp"

namespace standcal::test {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// --- CAN ------------------------------------------------------------------------------

struct RecordedFrame {
  std::uint32_t can_id;
  std::vector<std::uint8_t> data;
};

// "(seconds) iface ID#HEXDATA", candump -L's format; ids of 8 hex digits are extended.
RecordedFrame parse_candump_line(const std::string& line, const std::string& where) {
  std::istringstream in(line);
  std::string stamp, iface, frame;
  in >> stamp >> iface >> frame;
  const auto hash = frame.find('#');
  if (stamp.empty() || stamp[0] != '(' || hash == std::string::npos)
    throw std::runtime_error(where + ": not a candump -L line: " + line);
  RecordedFrame f;
  f.can_id = static_cast<std::uint32_t>(std::stoul(frame.substr(0, hash), nullptr, 16));
  if (hash == 8 && !(f.can_id & CAN_ERR_FLAG)) f.can_id |= CAN_EFF_FLAG;
  const std::string hex = frame.substr(hash + 1);
  if (hex.size() % 2 != 0 || hex.size() > 16)
    throw std::runtime_error(where + ": odd or over-long data in " + line);
  for (std::size_t i = 0; i < hex.size(); i += 2)
    f.data.push_back(static_cast<std::uint8_t>(std::stoul(hex.substr(i, 2), nullptr, 16)));
  return f;
}

std::string replay_can(const std::string& path) {
  std::vector<RecordedFrame> frames;
  const auto lines = lines_of(path);
  for (std::size_t i = 0; i < lines.size(); ++i) {
    if (lines[i].empty() || lines[i][0] == '#') continue;
    frames.push_back(parse_candump_line(lines[i], path + ":" + std::to_string(i + 1)));
  }
  drivers::can::testing::CanPair bus;
  drivers::can::SocketCanUnitConfig config;
  config.silence_timeout_s = 30;  // the replay is about the frames, not about their timing
  auto unit = drivers::can::SocketCanUnit::adopt_fd(
      bus.release_unit_fd(), drivers::can::FrameLayout::default_layout(), config);
  if (!unit) throw std::runtime_error(unit.status().message);
  if (!unit.value()->start()) throw std::runtime_error("start failed");
  // Written from a thread (the socketpair holds fewer datagrams than a recording has),
  // and only once collect() has begun: a sample that arrived before the call is not the
  // call's (SocketCanUnit::collect), as on a real bus. Half a second is ample for this
  // thread to enter collect() even on a busy machine; the frames then take milliseconds.
  std::thread writer([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(500));
    for (const RecordedFrame& f : frames)
      bus.send_classic(f.can_id, f.data.data(), static_cast<std::uint8_t>(f.data.size()));
  });
  auto samples = unit.value()->collect(2.5);
  writer.join();
  if (!samples) throw std::runtime_error(samples.status().message);
  std::ostringstream out;
  out << "# " << frames.size() << " frames replayed; samples: counter, x y z (m/s^2), temp (C)\n";
  char buf[160];
  for (const drivers::AccelSample& s : samples.value()) {
    std::snprintf(buf, sizeof buf, "%llu %.9g %.9g %.9g %.4g\n",
                  static_cast<unsigned long long>(s.counter), s.force_mps2[0], s.force_mps2[1],
                  s.force_mps2[2], s.temperature_c);
    out << buf;
  }
  const drivers::AccelUnitHealth h = unit.value()->health();
  out << "health frames " << h.frames << " samples " << h.samples << " incomplete "
      << h.incomplete_samples << " duplicate " << h.duplicate_frames << " late " << h.late_frames
      << " unknown " << h.unknown_frames << " resyncs " << h.counter_resyncs << " errors "
      << h.error_frames << "\n";
  return out.str();
}

class CanReplay : public ::testing::TestWithParam<std::string> {};

TEST_P(CanReplay, SamplesAndCountersMatchTheExpectedOutput) {
  const std::string base = std::string(STANDCAL_REPLAY_DIR) + "/can/" + GetParam();
  check_against(base + ".chk", replay_can(base + ".candump"));
}

INSTANTIATE_TEST_SUITE_P(Recorded, CanReplay, ::testing::ValuesIn(files_in("can", ".candump")),
                         [](const ::testing::TestParamInfo<std::string>& p) { return p.param; });

// --- JSON-RPC -------------------------------------------------------------------------

void mask_keys(json& j, const std::set<std::string>& keys) {
  if (j.is_object()) {
    for (auto it = j.begin(); it != j.end(); ++it) {
      if (keys.count(it.key()))
        it.value() = "<masked>";
      else
        mask_keys(it.value(), keys);
    }
  } else if (j.is_array()) {
    for (auto& v : j) mask_keys(v, keys);
  }
}

// A line a daemon answers: a JSON-RPC request with an id, or a line that is not JSON at all
// (answered with id null). A notification gets no answer.
bool expects_reply(const std::string& line) {
  const json j = json::parse(line, nullptr, false);
  return j.is_discarded() || !j.is_object() || j.contains("id");
}

std::string replay_session(const std::string& path) {
  std::set<std::string> masked;
  std::vector<std::string> requests;
  for (const std::string& line : lines_of(path)) {
    if (line.rfind("# mask:", 0) == 0) {
      std::istringstream keys(line.substr(7));
      for (std::string k; keys >> k;) masked.insert(k);
    } else if (!line.empty() && line[0] != '#') {
      requests.push_back(line);
    }
  }
  TempDir dir("standcal-replay");
  auto daemon = DaemonProcess::sim(dir.path(), 50);
  protocol::Client client(socket_of(dir));
  std::ostringstream out;
  for (const std::string& request : requests) {
    out << "> " << request << "\n";
    client.send_raw(request + "\n");
    if (!expects_reply(request)) {
      out << "< (notification: no reply)\n";
      continue;
    }
    std::optional<json> reply;
    // Events are not subscribed to, so the next message is the reply.
    reply = client.next_message(std::chrono::seconds(60));
    if (!reply) throw std::runtime_error(path + ": no reply to " + request);
    mask_keys(*reply, masked);
    out << "< " << reply->dump() << "\n";
  }
  return out.str();
}

class JsonRpcReplay : public ::testing::TestWithParam<std::string> {};

TEST_P(JsonRpcReplay, RepliesMatchTheExpectedOutput) {
  const std::string base = std::string(STANDCAL_REPLAY_DIR) + "/jsonrpc/" + GetParam();
  check_against(base + ".chk", replay_session(base + ".jsonl"));
}

INSTANTIATE_TEST_SUITE_P(Recorded, JsonRpcReplay,
                         ::testing::ValuesIn(files_in("jsonrpc", ".jsonl")),
                         [](const ::testing::TestParamInfo<std::string>& p) { return p.param; });

}  // namespace
}  // namespace standcal::test
