#pragma once
// The socket server: one epoll loop on one thread for every client (Unix socket, and the
// optional loopback TCP listener), the signals (signalfd), the systemd watchdog tick
// (timerfd) and the answers and events coming back from the sequencer (eventfd).
// Nothing here blocks: a client that stops reading is dropped once its unsent output
// passes a limit; a line longer than 64 KiB gets an error and the connection is closed;
// past max_clients a new connection gets a `too many clients` error and is closed.
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <vector>

#include "daemon/standcald/config.hpp"
#include "daemon/standcald/sequencer.hpp"
#include "protocol/jsonrpc/jsonrpc.hpp"
#include "protocol/jsonrpc/line_buffer.hpp"

namespace standcal::daemon {

class Server {
 public:
  static constexpr std::size_t kMaxUnsentBytes = 1024 * 1024;  // per client

  Server(const DaemonConfig& config, Sequencer& sequencer);
  ~Server();
  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;

  // Takes the socket systemd passed (socket activation) or binds config.socket_path,
  // replacing a stale socket file; opens the TCP listener when enabled. Throws with the
  // reason. SIGTERM/SIGINT must already be blocked in every thread.
  void open_listeners();
  int tcp_port() const { return tcp_port_; }
  // Runs until SIGTERM or SIGINT.
  void run();
  // Thread-safe: runs `job` on the server thread.
  void post(std::function<void()> job);
  // Thread-safe: sends an event notification to the clients that subscribed to it.
  void publish(const std::string& event, const nlohmann::json& params);

 private:
  struct Client {
    int fd = -1;
    std::uint64_t serial = 0;  // replies to a closed-and-reused fd must not reach a new client
    protocol::LineBuffer in{protocol::kMaxRequestBytes};
    std::string out;
    bool want_write = false;
    std::set<std::string> events;
  };

  void add_fd(int fd, std::uint32_t events);
  void accept_clients(int listen_fd);
  void read_client(Client& c);
  void handle_line(Client& c, const std::string& line);
  void send_line(Client& c, const std::string& line);
  void flush(Client& c);
  void reply_later(std::uint64_t serial, int fd, const nlohmann::json& id, Outcome outcome);
  nlohmann::json status() const;
  nlohmann::json subscribe(Client& c, const nlohmann::json& params);
  void run_posted();
  void watchdog_tick();

  const DaemonConfig& config_;
  Sequencer& sequencer_;
  int epoll_fd_ = -1;
  int unix_fd_ = -1;
  bool unix_from_systemd_ = false;
  int tcp_fd_ = -1;
  int tcp_port_ = 0;
  int signal_fd_ = -1;
  int wake_fd_ = -1;
  int timer_fd_ = -1;
  std::uint64_t next_serial_ = 1;
  std::map<int, std::unique_ptr<Client>> clients_;
  std::mutex posted_mutex_;
  std::vector<std::function<void()>> posted_;
  std::uint64_t last_heartbeat_ = 0;
  double started_s_ = 0;
  std::uint64_t requests_ = 0;
  std::uint64_t dropped_clients_ = 0;
  bool running_ = true;
};

}  // namespace standcal::daemon
