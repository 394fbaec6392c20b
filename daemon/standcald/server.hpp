#pragma once
// The socket server: one epoll loop on one thread for every client (Unix socket, and the
// optional TCP listener), the signals (signalfd), the systemd watchdog tick
// (timerfd) and the answers and events coming back from the sequencer (eventfd).
// Nothing here blocks: a client that stops reading is dropped once its unsent output
// passes client_queue_bytes; a line longer than 64 KiB gets an error and the connection is closed;
// a request line not ended within client_request_timeout_s, and a connection idle (no
// request, no answer pending, no subscription) for client_idle_timeout_s, are closed.
// Slots: the last kReservedControlSlots of max_clients only go to peers that hold the right
// to them (root, the daemon's user, the control group; known at accept from SO_PEERCRED),
// and past max_clients up to kEstopOnlySlots more connections may send one `estop` and
// nothing else, so a flood of idle clients never blocks an emergency stop.
#include <sys/types.h>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include "daemon/standcald/config.hpp"
#include "daemon/standcald/diagnose_job.hpp"
#include "daemon/standcald/method_table.hpp"
#include "daemon/standcald/pid_lock.hpp"
#include "daemon/standcald/sequencer.hpp"
#include "protocol/jsonrpc/jsonrpc.hpp"
#include "protocol/jsonrpc/line_buffer.hpp"

namespace standcal::daemon {

// --- Access control (docs/security.md) ------------------------------------------------
// Anyone who can connect may read (status, runs, results, events) and press `estop`.
// Commanding the stand or a run ("control") needs, on the Unix socket, membership of
// access.control_group when one is configured, and on TCP the token sent with `auth`
// (protocol::method::auth); a refusal is protocol::ErrorCode::not_permitted (-32009).

// Who is on the other end of one connection.
struct Peer {
  bool tcp = false;
  bool credentials_known = false;  // SO_PEERCRED answered (Unix socket only)
  pid_t pid = 0;
  uid_t uid = static_cast<uid_t>(-1);
  gid_t gid = static_cast<gid_t>(-1);
  std::vector<gid_t> groups;    // supplementary groups of the peer process
  std::string address;          // TCP: "127.0.0.1:53412"
  std::string process;          // Unix socket: the peer's process name (/proc/PID/comm) at accept
  bool token_accepted = false;  // TCP: sent the right token with `auth`
};

struct AccessPolicy {
  std::string control_group;  // empty: every Unix-socket peer may command
  gid_t control_gid = 0;      // control_group resolved at start
  uid_t daemon_uid = 0;       // the daemon's own user always may
  bool tcp_token_configured = false;
};

// Methods open to every connected client: the read-only views, the session methods and
// `estop` (anyone who sees the stand misbehave must be able to stop it). Everything
// else is a control method, including any method added later until it is listed here.
bool is_open_method(const std::string& method);
// Why `peer` may not call `method`, or nothing when it may. A pure function of its
// arguments, so the tests can check every case without sockets.
std::optional<std::string> refuse_control(const std::string& method, const Peer& peer,
                                          const AccessPolicy& policy);
// Compares a supplied token with the expected one in time that depends only on the
// supplied length (no early exit on the first differing byte).
bool tokens_equal(std::string_view supplied, std::string_view expected);
// "uid 1000 gid 1000 pid 4242" or "tcp 127.0.0.1:53412", for logs and messages.
std::string describe_peer(const Peer& peer);
// describe_peer plus the process name when known: "uid 0 gid 0 pid 4242 (standcal)".
std::string describe_peer_process(const Peer& peer);

// Connection slots kept back from everyone else (docs/security.md "Connection slots").
inline constexpr int kReservedControlSlots = 8;  // inside max_clients
inline constexpr int kEstopOnlySlots = 16;       // beyond max_clients, estop only
// Whether `peer` may take one of the reserved slots: a Unix-socket peer that is root, the
// daemon's user or a member of the control group. Not TCP: who holds the token is known
// only after `auth`, too late for the slot.
bool may_use_reserved_slot(const Peer& peer, const AccessPolicy& policy);

// Which slot a new connection gets, from the slots taken and the peer's right to a
// reserved one; nothing: refuse it (too many clients).
enum class ClientSlot { ordinary, reserved, estop_only };
struct SlotsTaken {
  int regular = 0;  // ordinary and reserved
  int estop_only = 0;
};
std::optional<ClientSlot> slot_for_new_client(const SlotsTaken& taken, int max_clients,
                                              bool may_use_reserved);

class Server {
 public:
  // The methods this class answers on its own thread (the method table's `server` rows).
  static std::vector<std::string_view> answered_methods();
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
    Peer peer;
    bool close_after_reply = false;  // e.g. after a wrong token
    ClientSlot slot = ClientSlot::ordinary;
    double connected_s = 0;
    double last_activity_s = 0;   // connect, last request or last answer to a pending call
    double partial_since_s = -1;  // when the unfinished request line began; < 0: none
    int pending_replies = 0;      // calls handed to the sequencer or a worker, unanswered
  };

  void open_unix_listener();
  void remember_bound_socket_file();
  void unlink_socket_file_if_ours() const;
  void open_tcp_listener();
  void resolve_access_policy();
  void add_fd(int fd, std::uint32_t events);
  void accept_clients(int listen_fd);
  void read_client(Client& c);
  void handle_line(Client& c, const std::string& line);
  nlohmann::json answer_here(Client& c, const protocol::Request& req);
  // The methods the socket thread answers (method_table.hpp's executor `server`), one
  // handler each.
  using ViewHandler = nlohmann::json (Server::*)(Client& c, const nlohmann::json& params);
  struct Binding {
    std::string_view method;
    ViewHandler answer;
  };
  static const Binding kBindings[];
  nlohmann::json status_view(Client& c, const nlohmann::json& params);
  nlohmann::json run_status_view(Client& c, const nlohmann::json& params);
  nlohmann::json run_result_view(Client& c, const nlohmann::json& params);
  nlohmann::json runs_list_view(Client& c, const nlohmann::json& params);
  void hand_on(Client& c, const protocol::Request& req, Executor executor);
  void send_line(Client& c, const std::string& line);
  void flush(Client& c);
  void reply_later(std::uint64_t serial, int fd, const nlohmann::json& id, Outcome outcome);
  nlohmann::json status(const Client& c) const;
  nlohmann::json authenticate(Client& c, const nlohmann::json& params);
  nlohmann::json subscribe(Client& c, const nlohmann::json& params);
  void run_posted();
  SlotsTaken slots_taken() const;
  void refuse_connection(int fd);
  void greet(Client& c);
  bool refuse_on_estop_only_slot(Client& c, const protocol::Request& req);
  void track_partial_request(Client& c);
  // The earliest moment some client's request or idle timeout falls due; < 0: none.
  double next_client_deadline_s() const;
  double client_deadline_s(const Client& c) const;
  void close_expired_clients();
  void close_with_error(Client& c, int code, const std::string& message,
                        const nlohmann::json& id = nullptr);
  void watchdog_tick();

  const DaemonConfig& config_;
  Sequencer& sequencer_;
  int epoll_fd_ = -1;
  int unix_fd_ = -1;
  bool unix_from_systemd_ = false;
  // The socket file this daemon bound (device and inode), the only one it may unlink:
  // never one another daemon bound, nor one systemd passed.
  bool unix_file_ours_ = false;
  dev_t unix_file_dev_ = 0;
  ino_t unix_file_ino_ = 0;
  // SOCKET.lock, held while this daemon owns the socket path: a second daemon never
  // replaces the socket of one still starting (bound, not yet listening).
  std::optional<PidLock> socket_lock_;
  int tcp_fd_ = -1;
  int tcp_port_ = 0;
  AccessPolicy policy_;
  std::string tcp_token_;
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
  // Last, so it is destroyed first: its worker must stop before the members it posts to.
  DiagnoseJobs diagnose_jobs_;
};

}  // namespace standcal::daemon
