// Modbus replay: `standcal stand` commands recorded against a controller (modbus/*.mbtrace,
// tests/replay/record_modbus.py) are run again against a replay controller that answers
// each read with the reply recorded for the same request, so the driver decodes the very
// bytes the controller sent then. The expected output (.chk) is what the operator saw
// (each command's output and exit status) and every register the driver wrote, except
// the heartbeat counter, whose number of writes depends on how long a command took.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <cstdio>
#include <deque>
#include <map>
#include <mutex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "drivers/modbus/register_map.hpp"
#include "tests/replay/replay_support.hpp"

namespace standcal::test {
namespace {

using Bytes = std::vector<std::uint8_t>;

// One request and the controller's reply: unit id, function code, data (no MBAP header).
struct Exchange {
  Bytes request;
  Bytes reply;
};

// One connection: the `standcal stand` arguments of the command that opened it, whether
// it is that command's first, and its exchanges.
struct RecordedConnection {
  std::string args;
  bool first_of_command = true;
  std::vector<Exchange> exchanges;
};

Bytes parse_hex(const std::string& text, const std::string& where) {
  Bytes out;
  std::istringstream in(text);
  for (std::string byte; in >> byte;) {
    if (byte.size() != 2) throw std::runtime_error(where + ": not a hex byte: " + byte);
    out.push_back(static_cast<std::uint8_t>(std::stoul(byte, nullptr, 16)));
  }
  if (out.size() < 2) throw std::runtime_error(where + ": too short for unit id and function");
  return out;
}

std::vector<RecordedConnection> read_trace(const std::string& path) {
  std::vector<RecordedConnection> connections;
  const auto lines = lines_of(path);
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const std::string& line = lines[i];
    const std::string where = path + ":" + std::to_string(i + 1);
    if (line.empty() || line[0] == '#') continue;
    if (line.rfind("@@", 0) == 0 && !connections.empty()) {
      connections.push_back({connections.back().args, false, {}});
    } else if (line.rfind("@ ", 0) == 0) {
      connections.push_back({line.substr(2), true, {}});
    } else if (line.rfind("> ", 0) == 0 && !connections.empty()) {
      connections.back().exchanges.push_back({parse_hex(line.substr(2), where), {}});
    } else if (line.rfind("< ", 0) == 0 && !connections.empty() &&
               !connections.back().exchanges.empty()) {
      connections.back().exchanges.back().reply = parse_hex(line.substr(2), where);
    } else {
      throw std::runtime_error(where + ": expected '@ ARGS', '@@', '> HEX' or '< HEX': " + line);
    }
  }
  return connections;
}

std::uint16_t word_at(const Bytes& b, std::size_t i) {
  return static_cast<std::uint16_t>(b[i] << 8 | b[i + 1]);
}

bool read_exactly(int fd, std::uint8_t* buf, std::size_t n) {
  for (std::size_t got = 0; got < n;) {
    const ssize_t r = ::recv(fd, buf + got, n - got, 0);
    if (r <= 0) return false;
    got += static_cast<std::size_t>(r);
  }
  return true;
}

// A Modbus TCP server on loopback that plays the recorded controller, one recorded
// connection per accepted connection, in order. Reads (functions 3 and 4) get the replies
// recorded for the same request, in recorded order, the last one again once they run out
// (a replayed wait may poll more often than the recorded one did); writes (6 and 16) get
// the reply Modbus defines for them. Anything else is an exception reply, logged.
class ReplayController {
 public:
  ReplayController(std::vector<RecordedConnection> connections, std::uint16_t heartbeat_register)
      : connections_(std::move(connections)), heartbeat_register_(heartbeat_register) {
    listen_fd_ = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t len = sizeof addr;
    if (::bind(listen_fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0 ||
        ::listen(listen_fd_, 1) != 0 ||
        ::getsockname(listen_fd_, reinterpret_cast<sockaddr*>(&addr), &len) != 0)
      throw std::runtime_error("replay controller: cannot listen on loopback");
    port_ = ntohs(addr.sin_port);
    thread_ = std::thread([this] { serve(); });
  }
  ~ReplayController() {
    stop_ = true;
    thread_.join();
    ::close(listen_fd_);
  }

  std::string url() const { return "tcp://127.0.0.1:" + std::to_string(port_) + "?unit=1"; }

  // What the driver did on connection `index` (its writes, unexpected requests), once
  // that connection has closed.
  std::string log_of(std::size_t index) {
    std::unique_lock lock(mutex_);
    done_.wait_for(lock, std::chrono::seconds(10), [&] { return logs_.size() > index; });
    return logs_.size() > index ? logs_[index] : "(the command did not connect)\n";
  }

 private:
  void serve() {
    for (std::size_t index = 0; index < connections_.size() && !stop_;) {
      pollfd p{listen_fd_, POLLIN, 0};
      if (::poll(&p, 1, 100) <= 0) continue;
      const int fd = ::accept(listen_fd_, nullptr, nullptr);
      if (fd < 0) continue;
      std::string log = answer(fd, connections_[index]);
      ::close(fd);
      std::lock_guard lock(mutex_);
      logs_.push_back(std::move(log));
      done_.notify_all();
      ++index;
    }
  }

  std::string answer(int fd, const RecordedConnection& recorded) {
    std::map<Bytes, std::deque<Bytes>> replies;  // read request → its recorded replies
    for (const Exchange& e : recorded.exchanges)
      if (e.request[1] == 3 || e.request[1] == 4) replies[e.request].push_back(e.reply);
    std::ostringstream log;
    std::uint8_t header[7];
    while (read_exactly(fd, header, sizeof header)) {
      const std::size_t length = static_cast<std::size_t>(header[4] << 8 | header[5]);
      Bytes request(length);
      request[0] = header[6];
      if (length < 2 || !read_exactly(fd, request.data() + 1, length - 1)) break;
      send_reply(fd, header, reply_to(request, replies, log));
    }
    return log.str();
  }

  Bytes reply_to(const Bytes& request, std::map<Bytes, std::deque<Bytes>>& replies,
                 std::ostringstream& log) const {
    const std::uint8_t function = request[1];
    if ((function == 3 || function == 4) && replies.count(request)) {
      std::deque<Bytes>& queue = replies[request];
      Bytes reply = queue.front();
      if (queue.size() > 1) queue.pop_front();
      return reply;
    }
    if (function == 6 && request.size() == 6) {
      log_write(log, word_at(request, 2), {word_at(request, 4)});
      return request;
    }
    if (function == 16 && request.size() >= 7) {
      std::vector<std::uint16_t> values;
      for (std::size_t i = 7; i + 1 < request.size(); i += 2) values.push_back(word_at(request, i));
      log_write(log, word_at(request, 2), values);
      return Bytes(request.begin(), request.begin() + 6);
    }
    log << "? unrecorded request";
    for (std::uint8_t b : request) log << ' ' << std::hex << int(b) << std::dec;
    log << "\n";
    return {request[0], static_cast<std::uint8_t>(function | 0x80), 0x02};
  }

  void log_write(std::ostringstream& log, std::uint16_t address,
                 const std::vector<std::uint16_t>& values) const {
    if (address == heartbeat_register_ && values.size() == 1) return;
    log << "w " << address << " =";
    for (std::uint16_t v : values) log << ' ' << v;
    log << "\n";
  }

  static void send_reply(int fd, const std::uint8_t* header, const Bytes& reply) {
    Bytes adu{header[0], header[1], 0, 0};
    adu.push_back(static_cast<std::uint8_t>(reply.size() >> 8));
    adu.push_back(static_cast<std::uint8_t>(reply.size() & 0xFF));
    adu.insert(adu.end(), reply.begin(), reply.end());
    (void)::send(fd, adu.data(), adu.size(), MSG_NOSIGNAL);
  }

  std::vector<RecordedConnection> connections_;
  std::uint16_t heartbeat_register_;
  int listen_fd_ = -1;
  int port_ = 0;
  std::atomic<bool> stop_{false};
  std::thread thread_;
  std::mutex mutex_;
  std::condition_variable done_;
  std::vector<std::string> logs_;
};

// Runs `standcal stand --url URL ARGS`: its exit status and its output (stdout and stderr),
// each line prefixed "| ", the replay controller's URL written as URL.
std::string run_stand_command(const std::string& url, const std::string& args) {
  const std::string command =
      std::string(STANDCAL_CLI_PATH) + " stand --url '" + url + "' " + args + " 2>&1";
  FILE* pipe = ::popen(command.c_str(), "r");
  if (pipe == nullptr) throw std::runtime_error("cannot run " + command);
  std::string text;
  char buf[512];
  while (std::fgets(buf, sizeof buf, pipe) != nullptr) text += buf;
  const int status = ::pclose(pipe);
  for (auto at = text.find(url); at != std::string::npos; at = text.find(url, at))
    text.replace(at, url.size(), "URL");
  std::ostringstream out;
  out << "exit " << (WIFEXITED(status) ? WEXITSTATUS(status) : -1) << "\n";
  std::istringstream lines(text);
  for (std::string line; std::getline(lines, line);) out << "| " << line << "\n";
  return out.str();
}

std::string replay_modbus(const std::string& path) {
  const std::vector<RecordedConnection> connections = read_trace(path);
  ReplayController controller(connections, drivers::modbus::RegisterMap{}.heartbeat);
  std::ostringstream out;
  const auto commands =
      std::count_if(connections.begin(), connections.end(),
                    [](const RecordedConnection& c) { return c.first_of_command; });
  out << "# " << commands << " commands replayed: each one's exit status and "
      << "output (|), the registers the driver wrote (w ADDRESS = VALUES; the heartbeat "
      << "counter left out)\n";
  for (std::size_t i = 0; i < connections.size(); ++i) {
    if (connections[i].first_of_command) {
      out << "@ " << connections[i].args << "\n";
      out << run_stand_command(controller.url(), connections[i].args);
    } else {
      out << "@@ another connection of the same command\n";
    }
    out << controller.log_of(i);
  }
  return out.str();
}

class ModbusReplay : public ::testing::TestWithParam<std::string> {};

TEST_P(ModbusReplay, CommandsAndWritesMatchTheExpectedOutput) {
  const std::string base = std::string(STANDCAL_REPLAY_DIR) + "/modbus/" + GetParam();
  check_against(base + ".chk", replay_modbus(base + ".mbtrace"));
}

INSTANTIATE_TEST_SUITE_P(Recorded, ModbusReplay,
                         ::testing::ValuesIn(files_in("modbus", ".mbtrace")),
                         [](const ::testing::TestParamInfo<std::string>& p) { return p.param; });

}  // namespace
}  // namespace standcal::test
