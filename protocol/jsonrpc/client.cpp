#include "protocol/jsonrpc/client.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <charconv>
#include <cstring>
#include <stdexcept>

#include "protocol/jsonrpc/methods.hpp"

namespace standcal::protocol {

using nlohmann::json;
using std::chrono::milliseconds;

namespace {

std::string errno_text() { return std::strerror(errno); }

int connect_unix(const std::string& path) {
  sockaddr_un addr{};
  if (path.size() >= sizeof(addr.sun_path))
    throw std::runtime_error("socket path too long: " + path);
  addr.sun_family = AF_UNIX;
  std::memcpy(addr.sun_path, path.c_str(), path.size() + 1);
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) throw std::runtime_error("cannot create a socket: " + errno_text());
  if (::connect(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof(addr)) != 0) {
    const std::string why = errno_text();
    ::close(fd);
    throw std::runtime_error("cannot connect to standcald at " + path + ": " + why +
                             " (is the daemon running? see `systemctl status standcald`)");
  }
  return fd;
}

int connect_tcp(const std::string& host_port) {
  const auto colon = host_port.rfind(':');
  if (colon == std::string::npos)
    throw std::runtime_error("TCP endpoint needs HOST:PORT: " + host_port);
  const auto port = parse_tcp_port(std::string_view(host_port).substr(colon + 1));
  if (!port)
    throw std::runtime_error("TCP endpoint " + host_port +
                             ": the port must be a number from 1 to 65535");
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(*port);
  if (::inet_pton(AF_INET, host_port.substr(0, colon).c_str(), &addr.sin_addr) != 1) {
    throw std::runtime_error("not an IPv4 address: " + host_port);
  }
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) throw std::runtime_error("cannot create a socket: " + errno_text());
  if (::connect(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof(addr)) != 0) {
    const std::string why = errno_text();
    ::close(fd);
    throw std::runtime_error("cannot connect to standcald at tcp://" + host_port + ": " + why);
  }
  return fd;
}

}  // namespace

std::optional<std::uint16_t> parse_tcp_port(std::string_view text) {
  unsigned value = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (text.empty() || ec != std::errc{} || end != text.data() + text.size()) return std::nullopt;
  if (value < 1 || value > 65535) return std::nullopt;
  return static_cast<std::uint16_t>(value);
}

Client::Client(const std::string& endpoint, milliseconds timeout) : endpoint_(endpoint) {
  const std::string tcp_prefix = "tcp://";
  fd_ = endpoint.rfind(tcp_prefix, 0) == 0 ? connect_tcp(endpoint.substr(tcp_prefix.size()))
                                           : connect_unix(endpoint);
  auto first = next_message(timeout);
  if (!first) {
    ::close(fd_);
    throw std::runtime_error("standcald at " + endpoint + " sent no greeting");
  }
  if (first->contains("error")) {
    const json& e = (*first)["error"];
    ::close(fd_);
    throw RpcError(e.value("code", -32603), e.value("message", std::string("refused")));
  }
  if (first->value("method", "") != method::hello) {
    ::close(fd_);
    throw std::runtime_error("standcald at " + endpoint + " did not greet with hello");
  }
  hello_ = first->value("params", json::object());
}

Client::~Client() {
  if (fd_ >= 0) ::close(fd_);
}

void Client::send_raw(const std::string& bytes) {
  std::size_t off = 0;
  while (off < bytes.size()) {
    const ssize_t n = ::send(fd_, bytes.data() + off, bytes.size() - off, MSG_NOSIGNAL);
    if (n < 0) {
      if (errno == EINTR) continue;
      throw std::runtime_error("lost the connection to standcald at " + endpoint_ + ": " +
                               errno_text());
    }
    off += static_cast<std::size_t>(n);
  }
}

std::optional<std::string> Client::read_line(milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  for (;;) {
    if (auto line = in_.next_line()) return line;
    const auto left =
        std::chrono::duration_cast<milliseconds>(deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0) return std::nullopt;
    pollfd p{fd_, POLLIN, 0};
    const int r = ::poll(&p, 1, static_cast<int>(left.count()));
    if (r < 0 && errno == EINTR) continue;
    if (r <= 0) return std::nullopt;
    char buf[65536];
    const ssize_t n = ::recv(fd_, buf, sizeof(buf), 0);
    if (n == 0) throw std::runtime_error("standcald at " + endpoint_ + " closed the connection");
    if (n < 0) {
      if (errno == EINTR || errno == EAGAIN) continue;
      throw std::runtime_error("lost the connection to standcald at " + endpoint_ + ": " +
                               errno_text());
    }
    in_.append(std::string_view(buf, static_cast<std::size_t>(n)));
  }
}

std::optional<json> Client::next_message(milliseconds timeout) {
  auto line = read_line(timeout);
  if (!line) return std::nullopt;
  json msg = json::parse(*line, nullptr, false);
  if (msg.is_discarded()) throw std::runtime_error("standcald sent a line that is not JSON");
  return msg;
}

std::optional<json> Client::next_notification(milliseconds timeout) {
  if (!notifications_.empty()) {
    json n = std::move(notifications_.front());
    notifications_.pop_front();
    return n;
  }
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  for (;;) {
    const auto left =
        std::chrono::duration_cast<milliseconds>(deadline - std::chrono::steady_clock::now());
    auto msg = next_message(std::max(left, milliseconds(0)));
    if (!msg) return std::nullopt;
    if (!msg->contains("id")) return msg;
  }
}

json Client::call(const std::string& method_name, const json& params, milliseconds timeout) {
  const long long id = next_id_++;
  send_raw(make_request(id, method_name, params) + "\n");
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  for (;;) {
    const auto left =
        std::chrono::duration_cast<milliseconds>(deadline - std::chrono::steady_clock::now());
    auto msg = next_message(std::max(left, milliseconds(0)));
    if (!msg)
      throw std::runtime_error("no answer from standcald to " + method_name + " within " +
                               std::to_string(timeout.count() / 1000) + " s");
    if (!msg->contains("id")) {
      notifications_.push_back(std::move(*msg));
      continue;
    }
    if ((*msg)["id"] != id) continue;  // an answer to an earlier, abandoned call
    if (msg->contains("error")) {
      const json& e = (*msg)["error"];
      throw RpcError(e.value("code", -32603), e.value("message", std::string("error")),
                     e.value("data", json()));
    }
    return msg->value("result", json());
  }
}

}  // namespace standcal::protocol
