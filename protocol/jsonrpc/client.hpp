#pragma once
// A blocking client of standcald: connects to the Unix socket (or a loopback TCP port),
// reads the `hello` greeting, sends requests and waits for their answers. Notifications
// that arrive meanwhile are queued for next_notification(). Used by the `standcal` CLI,
// the tests and the benchmark. Not thread-safe: one client per thread.
#include <chrono>
#include <cstdint>
#include <deque>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>

#include "protocol/jsonrpc/jsonrpc.hpp"
#include "protocol/jsonrpc/line_buffer.hpp"

namespace standcal::protocol {

// The PORT of a "HOST:PORT" endpoint: the whole text a decimal number from 1 to 65535,
// else nothing (no "4871x", no 99999 wrapping to 34463).
std::optional<std::uint16_t> parse_tcp_port(std::string_view text);

class Client {
 public:
  // Connects to "/path/to.sock" or "tcp://127.0.0.1:PORT" and reads the greeting; throws
  // std::runtime_error naming the endpoint when it cannot.
  explicit Client(const std::string& endpoint,
                  std::chrono::milliseconds timeout = std::chrono::seconds(10));
  ~Client();
  Client(const Client&) = delete;
  Client& operator=(const Client&) = delete;

  // The `hello` notification's params (daemon version, protocol version).
  const nlohmann::json& hello() const { return hello_; }

  // Sends a request and waits for its answer: the result, or throws RpcError with the
  // daemon's code and message; std::runtime_error when the connection fails or times out.
  nlohmann::json call(const std::string& method,
                      const nlohmann::json& params = nlohmann::json::object(),
                      std::chrono::milliseconds timeout = std::chrono::seconds(30));
  // Sends raw bytes (tests of malformed input).
  void send_raw(const std::string& bytes);
  // The next whole message (any kind); empty on timeout. Throws when the daemon closed.
  std::optional<nlohmann::json> next_message(std::chrono::milliseconds timeout);
  // The next notification (queued or new); empty on timeout.
  std::optional<nlohmann::json> next_notification(std::chrono::milliseconds timeout);
  int fd() const { return fd_; }

 private:
  std::optional<std::string> read_line(std::chrono::milliseconds timeout);

  std::string endpoint_;
  int fd_ = -1;
  LineBuffer in_{16 * 1024 * 1024};
  nlohmann::json hello_;
  std::deque<nlohmann::json> notifications_;
  long long next_id_ = 1;
};

}  // namespace standcal::protocol
